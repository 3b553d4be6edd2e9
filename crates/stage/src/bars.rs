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

#[cfg(test)]
mod tests {
    use super::*;

    /// 8 bars of 4/4 at 120 BPM: a note on each beat.
    fn song() -> Song {
        let mut track = Vec::new();
        for _ in 0..32 {
            track.extend_from_slice(&[0x00, 0x90, 60, 64, 0x83, 0x60, 0x80, 60, 0]);
        }
        track.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
        let mut smf = b"MThd\0\0\0\x06\0\0\0\x01\x01\xe0MTrk".to_vec();
        smf.extend_from_slice(&(track.len() as u32).to_be_bytes());
        smf.extend_from_slice(&track);
        Song::parse(&smf).unwrap()
    }

    #[test]
    fn bars_are_counted_from_1_to_the_last_and_no_further() {
        let song = song();
        assert_eq!(last_bar(&song), 8);
        assert_eq!(bar_start(&song, 1), Some(0));
        assert_eq!(bar_start(&song, 3), Some(4_000_000));
        assert_eq!(bar_start(&song, 0), None);
        assert_eq!(bar_start(&song, 9), None);
        let e = start_of(&song, 9).unwrap_err();
        assert_eq!(e.to_string(), "the song has bars 1 to 8");
        assert!(e.is_bad_input());
        assert_eq!(before(&song, 1), Some(0));
        assert_eq!(before(&song, 3), Some(2_000_000));
        assert_eq!(after(&song, 7), Some(14_000_000));
        assert_eq!(after(&song, 8), None);
    }

    #[test]
    fn a_bar_typed_takes_six_digits_goes_back_and_is_cleared_on_enter() {
        let song = song();
        let mut typed = Typed::default();
        assert_eq!(typed.shown(), None);
        for c in "1x2".chars() {
            typed.digit(c);
        }
        assert_eq!(typed.shown(), Some("12"));
        typed.back();
        assert_eq!(typed.enter(&song), Some(0));
        assert_eq!(typed.shown(), None, "cleared");
        for c in "4444444".chars() {
            typed.digit(c);
        }
        assert_eq!(typed.shown(), Some("444444"));
        assert_eq!(typed.enter(&song), None, "a bar the song lacks");
        typed.digit('5');
        assert_eq!(typed.enter(&song), Some(8_000_000));
    }
}
