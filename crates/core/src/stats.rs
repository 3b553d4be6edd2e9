//! What the interpreter did with the notes it was given.

/// Counts kept by the interpreter. Every Note-On with velocity above 0 is counted in
/// [`note_ons`](Self::note_ons) and then in exactly one of `played`, `folded` or a `dropped_*`
/// count, so they always add up.
///
/// Counts wrap at 2³².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Stats {
    /// Note-Ons with velocity above 0.
    pub note_ons: u32,
    /// Notes that sounded on their own key (or joined a key already down).
    pub played: u32,
    /// Notes that sounded on a key an octave or more away.
    pub folded: u32,
    /// Octaves moved, summed over folded notes.
    pub folded_octaves: u32,
    /// Notes on a channel not listened to.
    pub dropped_channel: u32,
    /// Notes outside the key range with the drop policy (or with no key of their pitch class).
    pub dropped_range: u32,
    /// Notes refused because `max_keys_down` keys were already down.
    pub dropped_power: u32,
    /// Notes waiting for their re-strike gap that were released, reset or switched off before
    /// they could strike.
    pub dropped_cancelled: u32,
    /// Strikes delayed by the re-strike gap.
    pub restrikes_delayed: u32,
    /// Keys released by the hold limit.
    pub cut_by_hold_limit: u32,
    /// Keys released by the watchdog or by missing Active Sensing.
    pub cut_by_watchdog: u32,
    /// The most keys down at once.
    pub peak_keys_down: u8,
}

impl Stats {
    /// All notes dropped, for any reason.
    pub const fn dropped(&self) -> u32 {
        self.dropped_channel + self.dropped_range + self.dropped_power + self.dropped_cancelled
    }
}
