//! A session's timeline as one host sees it: its tempo, the beat at any moment, whether it
//! plays and since when.

/// A Link session's timeline at one capture. Times are µs on the session's host clock (Link's
/// own: `CLOCK_MONOTONIC_RAW` on Linux); beats are the session's, aligned to a `quantum` (the
/// beats of a bar): two hosts may number beats differently, by whole quanta, and one host's
/// numbering may move by whole quanta when the session's timeline changes (see
/// [`Steer`](crate::Steer)), but every bar line falls at one moment on every host.
pub trait Timeline {
    /// Beats per minute.
    fn tempo(&self) -> f64;
    /// The beat playing at host time `host_us`.
    fn beat_at(&self, host_us: i64, quantum: f64) -> f64;
    /// The host time at which `beat` plays.
    fn time_at(&self, beat: f64, quantum: f64) -> i64;
    /// Whether the session plays (start/stop sync).
    fn is_playing(&self) -> bool;
    /// The host time at which the session began to play (or stopped).
    fn started_at(&self) -> i64;
}

/// A timeline of one tempo: beat `beat` at host time `at_us`, `bpm` beats a minute. The
/// session's own timeline between two changes, and a stand-in for one in tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// Beats per minute.
    pub bpm: f64,
    /// The anchor: host µs.
    pub at_us: i64,
    /// The anchor: the beat there.
    pub beat: f64,
    /// Whether the session plays.
    pub playing: bool,
    /// The beat at which it began to play (or stopped). Link keeps that beat, not the
    /// moment: after a tempo change the start is where that beat falls at the new tempo.
    pub started_beat: f64,
}

impl Line {
    /// From `at_us` on, play at `bpm`, the beat there unmoved (as a Link peer changes tempo).
    pub fn change_tempo(&mut self, at_us: i64, bpm: f64) {
        self.beat = self.beat_at(at_us, 4.0);
        self.at_us = at_us;
        self.bpm = bpm;
    }
}

impl Timeline for Line {
    fn tempo(&self) -> f64 {
        self.bpm
    }

    fn beat_at(&self, host_us: i64, _quantum: f64) -> f64 {
        self.beat + (host_us - self.at_us) as f64 * self.bpm / 60e6
    }

    fn time_at(&self, beat: f64, _quantum: f64) -> i64 {
        self.at_us + ((beat - self.beat) * 60e6 / self.bpm).round() as i64
    }

    fn is_playing(&self) -> bool {
        self.playing
    }

    fn started_at(&self) -> i64 {
        self.time_at(self.started_beat, 4.0)
    }
}
