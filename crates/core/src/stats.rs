//! What the interpreter did with the notes it was given.

/// Counts kept by the interpreter, for a quick look; the per-note account is the
/// [`NoteEvent`](crate::NoteEvent)s.
///
/// Every Note-On with velocity above 0 is counted in [`note_ons`](Self::note_ons) at once, and
/// in exactly one of [`played`](Self::played), [`folded`](Self::folded) or a `dropped_*` count
/// as soon as its fate is known: when it strikes, joins a key already down, or is refused. A
/// strike that waits for the re-strike gap is in none of them until it strikes (or is
/// cancelled or stopped), so `note_ons == played + folded + dropped()` holds whenever no
/// strike is waiting, and `note_ons - (played + folded + dropped())` is the number of notes
/// waiting.
///
/// The other counts ([`folded_octaves`](Self::folded_octaves), [`joined`](Self::joined),
/// [`restrikes_delayed`](Self::restrikes_delayed), the `cut_by_*` counts and
/// [`peak_keys_down`](Self::peak_keys_down)) are not part of that sum.
///
/// The counts are plain `u32` additions: past 2³² − 1 (four thousand million notes) a debug
/// build panics on the overflow and a release build wraps to 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Stats {
    /// Note-Ons with velocity above 0 (a Note-On with velocity 0 is a Note-Off), on any
    /// channel and any note, counted on arrival.
    pub note_ons: u32,
    /// Notes in the key range that sounded: struck their key (at once, or late after the
    /// re-strike gap) or joined a key another note already holds down (see `joined`).
    pub played: u32,
    /// The same for notes moved into range by octaves ([`OutOfRange::Fold`]).
    ///
    /// [`OutOfRange::Fold`]: crate::OutOfRange::Fold
    pub folded: u32,
    /// Octaves moved, summed over every note that was folded into range, including folded
    /// notes then dropped.
    pub folded_octaves: u32,
    /// Of `played` and `folded`: notes that joined a key already down or about to strike,
    /// without a strike of their own.
    pub joined: u32,
    /// Notes on a channel not listened to.
    pub dropped_channel: u32,
    /// Notes on channel 10 (General MIDI's percussion) that no group listens to: by default
    /// a keyboard leaves them alone, and a drum group would play them.
    pub dropped_percussion: u32,
    /// Notes a strike group listens to but has no output for (a drum the kit lacks).
    pub dropped_unmapped: u32,
    /// Notes with no key: outside the key range with the drop policy, or with the fold policy
    /// on a range too narrow to hold their pitch class.
    pub dropped_range: u32,
    /// Notes refused because `max_keys_down` keys were already down or waiting to strike (only
    /// while the guard is on), or because the store of held notes was full
    /// ([`NotePool`](crate::NotePool)). Keys already down are never cut for a new note.
    pub dropped_power: u32,
    /// Re-strikes that would have waited longer than the guard's `late_limit` for their key's
    /// rest: refused, the key left as it was. On a fingered group: notes released before their
    /// fingers settled and taken over by the next.
    pub dropped_too_fast: u32,
    /// Notes of a chord a one-voice (fingered) group did not play.
    pub dropped_monophonic: u32,
    /// Strikes waiting for their re-strike gap that never struck: taken over by a later note
    /// on the key, or released with everything by a System Reset, the watchdog or missing
    /// Active Sensing. A waiting strike whose note merely ends (a Note-Off, All Notes Off) is
    /// not cancelled: it still strikes and is held for `min_press`.
    pub dropped_cancelled: u32,
    /// Strikes waiting for their re-strike gap when [`all_off`](crate::Interpreter::all_off)
    /// stopped everything.
    pub dropped_stopped: u32,
    /// Strikes delayed by the re-strike gap, counted when the delay starts (a delayed strike
    /// later cancelled or stopped is counted here too, and in `dropped_cancelled` or
    /// `dropped_stopped`).
    pub restrikes_delayed: u32,
    /// Keys released by the hold limit (`max_hold`), one per key each time; the notes holding
    /// the key are forgotten.
    pub cut_by_hold_limit: u32,
    /// Keys released by the duty limit (`duty`), one per key each time; the notes holding the
    /// key are forgotten.
    pub cut_by_duty_limit: u32,
    /// Keys down when the watchdog or missing Active Sensing released everything, summed
    /// over every time it fired (strikes still waiting are counted in `dropped_cancelled`).
    pub cut_by_watchdog: u32,
    /// Lead and damper pulses not fired (no note's: an open hi-hat's lift, a bar's damper):
    /// their output was still within its rebound, or the power budget was full. The note
    /// itself is counted as any other.
    #[cfg(feature = "strike")]
    pub extras_skipped: u32,
    /// The most keys down at once (powered; strikes waiting for their gap are not down).
    pub peak_keys_down: u8,
}

impl Stats {
    /// All notes dropped, for any reason: `dropped_channel + dropped_percussion +
    /// dropped_unmapped + dropped_range + dropped_power + dropped_too_fast +
    /// dropped_monophonic + dropped_cancelled + dropped_stopped`.
    pub const fn dropped(&self) -> u32 {
        self.dropped_channel
            + self.dropped_percussion
            + self.dropped_unmapped
            + self.dropped_range
            + self.dropped_power
            + self.dropped_too_fast
            + self.dropped_monophonic
            + self.dropped_cancelled
            + self.dropped_stopped
    }
}
