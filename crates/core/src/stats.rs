//! What the interpreter did with the notes it was given.

/// Counts kept by the interpreter, for a quick look; the per-note account is the
/// [`NoteEvent`](crate::NoteEvent)s.
///
/// Every Note-On with velocity above 0 is counted in [`note_ons`](Self::note_ons) and, once
/// its fate is known, in exactly one of `played`, `folded` or a `dropped_*` count: at once,
/// except a note waiting for its re-strike gap, which is counted when it strikes (in `played`
/// or `folded`) or is cancelled or stopped. So `note_ons == played + folded + dropped()` once
/// no note is waiting.
///
/// Counts wrap at 2³².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Stats {
    /// Note-Ons with velocity above 0.
    pub note_ons: u32,
    /// Notes on their own key (not folded) that struck it or joined it (see `joined`).
    pub played: u32,
    /// Notes folded onto a key an octave or more away that struck it or joined it.
    pub folded: u32,
    /// Octaves moved, summed over every note that was folded (whatever became of it).
    pub folded_octaves: u32,
    /// Of `played` and `folded`: notes that joined a key already down or about to strike,
    /// without a strike of their own.
    pub joined: u32,
    /// Notes on a channel not listened to.
    pub dropped_channel: u32,
    /// Notes outside the key range with the drop policy (or with no key of their pitch class).
    pub dropped_range: u32,
    /// Notes refused because `max_keys_down` keys were already down (or struck or waiting),
    /// or because the store of held notes was full.
    pub dropped_power: u32,
    /// Re-strikes that would have waited longer than the guard's `late_limit` for their key's
    /// rest.
    pub dropped_too_fast: u32,
    /// Notes waiting for their re-strike gap whose strike was taken over by a later note on
    /// the key, or that a System Reset, the watchdog or missing Active Sensing cancelled.
    pub dropped_cancelled: u32,
    /// Notes waiting for their re-strike gap when [`all_off`](crate::Interpreter::all_off)
    /// stopped everything.
    pub dropped_stopped: u32,
    /// Strikes delayed by the re-strike gap (each later struck, or was cancelled or stopped).
    pub restrikes_delayed: u32,
    /// Keys released by the hold limit.
    pub cut_by_hold_limit: u32,
    /// Keys released by the duty limit.
    pub cut_by_duty_limit: u32,
    /// Keys released by the watchdog or by missing Active Sensing (keys down at that moment).
    pub cut_by_watchdog: u32,
    /// The most keys down at once.
    pub peak_keys_down: u8,
}

impl Stats {
    /// All notes dropped, for any reason.
    pub const fn dropped(&self) -> u32 {
        self.dropped_channel
            + self.dropped_range
            + self.dropped_power
            + self.dropped_too_fast
            + self.dropped_cancelled
            + self.dropped_stopped
    }
}
