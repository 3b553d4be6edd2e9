//! Leading the session: a performance that follows a conductor (baton, taps, MIDI clock, OSC)
//! tells the session its tempo and phase, so robots on other hosts follow the one conductor.
//!
//! The session's beat is the performance's quarter from bar one; its tempo is the
//! performance's quarters a minute (the tempo factor over the score's quarter where it
//! stands). Each look ([`Lead::step`]) says what to publish: a tempo that differs from the
//! session's by more than [`TEMPO_SLACK`], and a beat that has drifted from the
//! performance's by more than [`PHASE_SLACK_US`] (a tempo published a look late leaves a
//! little; forcing the beat makes it up).

use orch_perform::{ScoreBeats, TimeMap};

use crate::timeline::Timeline;

/// The relative difference of tempo below which the session's is left.
pub const TEMPO_SLACK: f64 = 1e-4;

/// How far the session's beat may drift from the performance's before it is forced, µs.
pub const PHASE_SLACK_US: f64 = 300.0;

/// What a look publishes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Publish {
    /// Nothing: the session is where the performance is.
    Nothing,
    /// The performance's tempo (BPM), from now.
    Tempo(f64),
    /// The performance's tempo (BPM), and its beat now (the session's beat forced there).
    Beat(f64, f64),
}

/// Tells the session where a performance stands. See the [module notes](self).
#[derive(Clone, Debug)]
pub struct Lead {
    beats: ScoreBeats,
    quantum: f64,
    bar_one: f64,
}

impl Lead {
    /// For a score whose quarters are `beats`, with bar one at the session's beat `bar_one`
    /// (bars of `quantum` beats).
    pub fn new(beats: ScoreBeats, quantum: f64, bar_one: f64) -> Self {
        Self {
            beats,
            quantum,
            bar_one,
        }
    }

    /// The session's tempo (BPM) and beat that match the performance of `map` at wall time
    /// `wall`.
    pub fn at(&self, map: &TimeMap, wall: i64) -> (f64, f64) {
        let (quarter, len) = self.beats.at(map.score(wall));
        (map.tempo().get() * 60e6 / len, self.bar_one + quarter)
    }

    /// One look at host time `host`, wall time `wall` (read together).
    pub fn step(&self, timeline: &impl Timeline, host: i64, wall: i64, map: &TimeMap) -> Publish {
        // Before bar one nothing moves: the session was started for it.
        if map.wall(0) > wall {
            return Publish::Nothing;
        }
        let (bpm, beat) = self.at(map, wall);
        // Within a bar: whole bars are this host's count of beats moving, which no other peer
        // sees (see [`Steer`](crate::Steer)'s notes).
        let drift = timeline.beat_at(host, self.quantum) - beat;
        let drift_us = (drift - (drift / self.quantum).round() * self.quantum) * 60e6 / bpm;
        if drift_us.abs() > PHASE_SLACK_US {
            Publish::Beat(bpm, beat)
        } else if (timeline.tempo() / bpm - 1.0).abs() > TEMPO_SLACK {
            Publish::Tempo(bpm)
        } else {
            Publish::Nothing
        }
    }
}

/// How much further before bar one than [`LEAD_IN_BEATS`](crate::LEAD_IN_BEATS) a leader
/// starts the session, beats: so that rounding never puts bar one a bar later.
pub const LEAD_IN_MARGIN: f64 = 1e-3;

/// When a session (showing `timeline` at host time `host`) that a performance leads begins:
/// the first bar line at least `lead_us` from now, as host µs and beat. The session is
/// started [`LEAD_IN_BEATS`](crate::LEAD_IN_BEATS) and [`LEAD_IN_MARGIN`] before it, so
/// every peer finds that bar line for bar one.
pub fn bar_line_after(
    timeline: &impl Timeline,
    host: i64,
    lead_us: i64,
    quantum: f64,
) -> (i64, f64) {
    let beat = (timeline.beat_at(host + lead_us, quantum) / quantum).ceil() * quantum;
    (timeline.time_at(beat, quantum), beat)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entry::bar_one;
    use crate::timeline::Line;
    use crate::LEAD_IN_BEATS;
    use orch_perform::Tempo;

    fn line() -> Line {
        Line {
            bpm: 100.0,
            at_us: 0,
            beat: 0.5,
            playing: false,
            started_beat: 0.5,
        }
    }

    #[test]
    fn the_session_started_so_finds_the_bar_line_for_bar_one() {
        let mut l = line();
        // From 1 s, at least 1 s on: beat 4, 3.5 beats (2.1 s) from beat 0.5 at 0.
        let (at, beat) = bar_line_after(&l, 1_000_000, 1_000_000, 4.0);
        assert_eq!((at, beat), (2_100_000, 4.0));
        l.playing = true;
        l.started_beat = beat - LEAD_IN_BEATS - LEAD_IN_MARGIN;
        assert_eq!(bar_one(&l, 4.0), beat);
    }

    #[test]
    fn a_performance_publishes_its_tempo_and_its_drift() {
        // Quarters of 600 ms (100 BPM) played twice as fast: 200 BPM.
        let beats = ScoreBeats::from_times((0..100).map(|q| q * 600_000).collect());
        let lead = Lead::new(beats, 4.0, 8.0);
        let map = TimeMap::new(1_000_000, Tempo::new(2.0).unwrap());
        assert_eq!(lead.at(&map, 1_300_000), (200.0, 9.0));
        let mut l = line();
        l.bpm = 200.0;
        l.at_us = 1_000_000;
        l.beat = 8.0;
        assert_eq!(lead.step(&l, 1_300_000, 1_300_000, &map), Publish::Nothing);
        // This host's count a bar behind: the same phase, nothing to publish.
        l.beat = 4.0;
        assert_eq!(lead.step(&l, 1_300_000, 1_300_000, &map), Publish::Nothing);
        l.bpm = 100.0;
        l.beat = 8.5;
        assert_eq!(
            lead.step(&l, 1_000_000, 1_000_000, &map),
            Publish::Beat(200.0, 8.0)
        );
        l.beat = 8.0;
        assert_eq!(
            lead.step(&l, 1_000_000, 1_000_000, &map),
            Publish::Tempo(200.0)
        );
        // Before bar one, nothing.
        assert_eq!(lead.step(&l, 900_000, 900_000, &map), Publish::Nothing);
    }
}
