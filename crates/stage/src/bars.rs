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
