//! Bars as people count them: from 1, by the song's time signatures (4/4 until the first).
//! Where a bar begins, for a jump there (`--from`, a bar typed in the live view).

use orch_seq::Song;

use crate::StageError;

/// The song's last bar (the bar of its last instant).
pub fn last_bar(song: &Song) -> u32 {
    song.bar_beat(song.duration_us().saturating_sub(1)).0
}

/// Where bar `bar` begins, µs of score time, if the song has it.
pub fn bar_start(song: &Song, bar: u32) -> Option<u64> {
    (1..=last_bar(song))
        .contains(&bar)
        .then(|| song.bar_start_us(bar))
        .flatten()
}

/// Where bar `bar` begins, µs of score time; [`StageError::NoSuchBar`] for a bar the song
/// does not have.
pub fn start_of(song: &Song, bar: u32) -> Result<u64, StageError> {
    bar_start(song, bar).ok_or(StageError::NoSuchBar {
        bar,
        last: last_bar(song),
    })
}

/// Where the bar before `bar` begins (bar 1's start from bar 1), if the song has it.
pub fn before(song: &Song, bar: u32) -> Option<u64> {
    bar_start(song, bar.saturating_sub(1).max(1))
}

/// Where the bar after `bar` begins, if the song has it.
pub fn after(song: &Song, bar: u32) -> Option<u64> {
    bar_start(song, bar.saturating_add(1))
}

/// A bar being typed to jump to, a digit at a time (at most 6), as a live view takes it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Typed(String);

impl Typed {
    /// Another digit (`'0'..='9'`; anything else, or a seventh digit, is not taken).
    pub fn digit(&mut self, c: char) {
        if c.is_ascii_digit() && self.0.len() < 6 {
            self.0.push(c);
        }
    }

    /// Takes the last digit back.
    pub fn back(&mut self) {
        self.0.pop();
    }

    /// The digits so far, if any.
    pub fn shown(&self) -> Option<&str> {
        (!self.0.is_empty()).then_some(self.0.as_str())
    }

    /// The bar typed is done: where it begins, if the song has it; the digits are cleared.
    pub fn enter(&mut self, song: &Song) -> Option<u64> {
        let bar = std::mem::take(&mut self.0).parse().ok()?;
        bar_start(song, bar)
    }
}
