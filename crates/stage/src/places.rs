//! Where each note of a performance stands in its song: the score time its bar and beat are
//! counted from, whatever the tempo did on the way.
//!
//! A performance's account knows each note's wall time; a bar is counted in score time.
//! Through a change of tempo (a Link session's, a conductor's, the page's) wall time is no
//! fixed multiple of score time, so the note's own score time is taken instead: in a
//! performance that never jumped back, record `i` is the `i`-th Note-On of the events the
//! robot was given (the song's, or its channels' of it). A note played again after a jump
//! back is a record past those; it is placed by its wall time at the tempo the performance
//! began at.

use orch_io::Channels;
use orch_perform::{Played, Tempo};
use orch_seq::Song;

use crate::session::lane_events;

/// The score time of each note of one robot's performance. See the [module notes](self).
#[derive(Clone, Debug)]
pub struct Places {
    /// The score time of each Note-On the robot was given, µs, in order.
    note_on_us: Vec<u64>,
    /// Whether record `i` is Note-On `i` (no jump back).
    by_index: bool,
    tempo: Tempo,
}

impl Places {
    /// The places of `played`, a performance of `song`'s `channels` begun at `tempo`.
    pub fn of(song: &Song, played: &Played, channels: Channels, tempo: Tempo) -> Self {
        let (events, _) = lane_events(song, channels);
        let note_on_us: Vec<u64> = events
            .iter()
            .filter(|e| e.bytes.note_on().is_some())
            .map(|e| e.score_us)
            .collect();
        let by_index = played.replayed == 0 && played.records.len() == note_on_us.len();
        Self {
            note_on_us,
            by_index,
            tempo,
        }
    }

    /// Record `record`'s score time, µs; `t_ms` is its wall time from the performance's
    /// start, for a note played again after a jump back.
    pub fn score_us(&self, record: usize, t_ms: f64) -> u64 {
        match self.note_on_us.get(record).filter(|_| self.by_index) {
            Some(&us) => us,
            None => (t_ms * 1000.0 * self.tempo.get()).round() as u64,
        }
    }

    /// Record `record`'s bar and beat in `song`.
    pub fn bar_beat(&self, song: &Song, record: usize, t_ms: f64) -> (u32, u32) {
        song.bar_beat(self.score_us(record, t_ms))
    }
}
