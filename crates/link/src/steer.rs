//! Keeping a performance on the session's beat: a tempo factor each moment, a jump when the
//! session's beat jumps.
//!
//! A score quarter note is one session beat, from bar one. Each look ([`Steer::step`]) sets
//! the performance's tempo factor to the ratio of the score's quarter where it stands (the
//! file's own tempo map) to the session's beat, plus a pull that makes up the error it finds
//! (the performance's quarter against the session's beat) over a short [`HORIZON_US`].
//! Between two changes of tempo (the session's, or the file's) that factor is constant and the
//! performance stays on the beat; a change is followed from the next look (a session's
//! change keeps its beat where it was, so it leaves no error; a file's change leaves as
//! much as one look's worth, made up over the horizon). Factors that differ from the one
//! playing by less than [`SLACK`] are left alone (a new factor re-plans what is queued).
//!
//! When the performance stands more than [`JUMP_QUARTERS`] from the session's beat (the
//! session's beat jumped: a peer forced it, or two sessions met), a factor would rush or
//! drag a whole passage: it jumps to the place the session will be at once its lookahead
//! has passed, instead.
//!
//! **The error is taken within a bar.** A Link session shares the *phase* of its beat within
//! the quantum, not the count of beats: each host numbers them its own way, and its count may
//! move by whole bars. It does so at a tempo change, when the host's own count stands half a
//! bar from the session's (Link keeps each host's count continuous, but the nearest bar-aligned
//! count to it then flips; seen in a test run: a robot jumped a bar back at 100 → 130 BPM). So
//! an error of whole bars is the count moving, not the music: the performance goes on where it
//! is, and whole bars are left out of the error.

use orch_perform::{ScoreBeats, Tempo, TimeMap};

use crate::entry::Entry;
use crate::timeline::Timeline;

/// How far ahead each look aims, µs of host time.
pub const HORIZON_US: i64 = 50_000;

/// The relative change of factor below which the factor playing is kept.
pub const SLACK: f64 = 2e-4;

/// How far from the session's beat (quarters) the performance jumps rather than being pulled.
pub const JUMP_QUARTERS: f64 = 0.25;

/// What a look asks of the performance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// Nothing: it is on the beat, or has not started.
    Hold,
    /// Play at this factor from now on.
    Tempo(Tempo),
    /// Jump to this score time (µs).
    Jump(u64),
    /// The session stopped: stop, every key up.
    Stop,
}

/// Keeps one performance on the session's beat. See the [module notes](self).
#[derive(Clone, Debug)]
pub struct Steer {
    beats: ScoreBeats,
    quantum: f64,
    entry: Entry,
    lookahead_us: i64,
}

impl Steer {
    /// For a score whose quarters are `beats`, a bar of `quantum` beats, coming in at
    /// `entry`, with a planner reading `lookahead_us` ahead.
    pub fn new(beats: ScoreBeats, quantum: f64, entry: Entry, lookahead_us: i64) -> Self {
        Self {
            beats,
            quantum,
            entry,
            lookahead_us,
        }
    }

    /// The score time (µs) of the place the robot comes in at.
    pub fn entry_score_us(&self) -> u64 {
        self.beats.time_of(f64::from(self.entry.quarter))
    }

    /// The tempo factor that plays a score quarter in one beat of `bpm` at score time
    /// `score_us`.
    pub fn factor_at(&self, score_us: u64, bpm: f64) -> Option<Tempo> {
        Tempo::new(self.beats.at(score_us).1 * bpm / 60e6)
    }

    /// The score's quarter at host time `host_us` on `timeline` (negative before bar one).
    fn quarter_at(&self, timeline: &impl Timeline, host_us: i64) -> f64 {
        timeline.beat_at(host_us, self.quantum) - self.entry.bar_one
    }

    /// One look at host time `host_now`, wall time `wall_now` on the performer's clock (the
    /// two read together), the performance's map being `map`.
    pub fn step(
        &self,
        timeline: &impl Timeline,
        host_now: i64,
        wall_now: i64,
        map: &TimeMap,
    ) -> Step {
        if !timeline.is_playing() {
            return Step::Stop;
        }
        let entry = self.entry_score_us();
        // Not started yet: its start is set, its first notes maybe sent.
        if map.wall(entry) > wall_now {
            return Step::Hold;
        }
        let now = map.score(wall_now);
        let (quarter, len) = self.beats.at(now);
        let raw = quarter - self.quarter_at(timeline, host_now);
        // Whole bars are this host's count of beats moving (see the module notes).
        let bars = (raw / self.quantum).round() * self.quantum;
        let error = raw - bars;
        if error.abs() > JUMP_QUARTERS {
            let q = (self.quarter_at(timeline, host_now + self.lookahead_us) + bars).max(0.0);
            return Step::Jump(self.beats.time_of(q));
        }
        // The even factor here (a quarter of this length in one beat), and the error (score
        // µs) made up over the horizon; a pull never plays a quarter in less than 0.75 or more
        // than 1.25 of a beat.
        let even = len * timeline.tempo() / 60e6;
        let factor = (even - error * len / HORIZON_US as f64).clamp(0.75 * even, 1.25 * even);
        match Tempo::new(factor) {
            Some(t) if (t.get() / map.tempo().get() - 1.0).abs() > SLACK => Step::Tempo(t),
            _ => Step::Hold,
        }
    }
}
