//! Where a robot comes in: bar one, shared by every peer, and the first beat this robot can
//! make.
//!
//! **Bar one** is the first bar line (a multiple of the quantum) at least [`LEAD_IN_BEATS`]
//! after the beat at which the session began to play. Every peer reads that beat from the
//! session, so every peer finds the same bar line, whatever its own mechanics, and whenever
//! it heard of the start. The lead-in leaves time for the news of a start to reach every host
//! and for each robot's first notes to be sent early.
//!
//! The lead-in is a count of beats, not a time, because a session keeps the *beat* at which it
//! began to play, not the moment: after a tempo change, Link maps that beat to the moment it
//! would have played at the new tempo. A lead-in of so many milliseconds, turned into beats at
//! the tempo of the moment, put a robot that joined after a change a bar away from the others
//! whenever the start fell just so (seen: 100 → 130 BPM, a start 0.5–0.65 beat before a bar
//! line).
//!
//! **The entry** is bar one if this robot can still make it (its planner's lookahead, and a
//! margin for setting up, before it); else the first beat after that which it can make: a
//! robot joining a session that already plays comes in at the session's present beat, the
//! score's bar and beat there, the notes before skipped.

use crate::timeline::Timeline;

/// The fewest beats from a session's start to bar one: half a second at 120 BPM, 250 ms at
/// 240. Beats, not a time: see the [module notes](self).
pub const LEAD_IN_BEATS: f64 = 1.0;

/// Where a robot comes in. See the [module notes](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// Bar one, in the session's beats (as this host numbers them).
    pub bar_one: f64,
    /// The score's quarter note this robot comes in at (0: bar one).
    pub quarter: u32,
    /// When it comes in, host µs.
    pub host_us: i64,
}

/// Bar one of the session that `timeline` shows playing, for a bar of `quantum` beats.
pub fn bar_one(timeline: &impl Timeline, quantum: f64) -> f64 {
    let start = timeline.beat_at(timeline.started_at(), quantum);
    ((start + LEAD_IN_BEATS) / quantum).ceil() * quantum
}

/// Where a robot that needs `ready_us` from now (`host_now`) before its first place plays
/// comes in.
pub fn entry(timeline: &impl Timeline, quantum: f64, host_now: i64, ready_us: i64) -> Entry {
    let bar_one = bar_one(timeline, quantum);
    let earliest = timeline.beat_at(host_now + ready_us, quantum) - bar_one;
    // A beat computed a hair after a whole one (rounding) is that beat.
    let quarter = (earliest - 1e-9).max(0.0).ceil() as u32;
    Entry {
        bar_one,
        quarter,
        host_us: timeline.time_at(bar_one + f64::from(quarter), quantum),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timeline::Line;

    fn line(beat_at_start: f64) -> Line {
        Line {
            bpm: 120.0,
            at_us: 1_000_000,
            beat: beat_at_start,
            playing: true,
            started_beat: beat_at_start,
        }
    }

    #[test]
    fn bar_one_is_the_first_bar_line_after_the_lead_in() {
        // Started on a bar line: the lead-in (a beat) puts bar one a bar later.
        assert_eq!(bar_one(&line(8.0), 4.0), 12.0);
        // Started mid-bar, with room: the next bar line.
        assert_eq!(bar_one(&line(9.0), 4.0), 12.0);
        // Too close to the next bar line: the one after.
        assert_eq!(bar_one(&line(11.5), 4.0), 16.0);
        // Hosts that number beats a quantum apart find the same moment.
        let (a, b) = (line(9.0), line(5.0));
        assert_eq!(
            a.time_at(bar_one(&a, 4.0), 4.0),
            b.time_at(bar_one(&b, 4.0), 4.0)
        );
    }

    #[test]
    fn a_tempo_change_moves_no_one_s_bar_one() {
        // Started at beat 7.4 at 100 BPM; a newcomer reads the start after a change to 130
        // (the beat of the start kept, as Link keeps it): the same bar line. (With a lead-in
        // of 300 ms, half a beat at 100 and 0.65 at 130, the two were a bar apart.)
        let mut l = line(7.4);
        l.bpm = 100.0;
        let before = bar_one(&l, 4.0);
        l.change_tempo(9_000_000, 130.0);
        assert!((l.beat_at(l.started_at(), 4.0) - 7.4).abs() < 1e-6);
        assert_eq!((before, bar_one(&l, 4.0)), (12.0, 12.0));
    }

    #[test]
    fn a_robot_comes_in_at_the_first_beat_it_can_make() {
        let l = line(8.0);
        // At the start, with 100 ms to get ready: bar one (beat 12, 2 s after the start).
        let e = entry(&l, 4.0, 1_000_000, 100_000);
        assert_eq!((e.bar_one, e.quarter, e.host_us), (12.0, 0, 3_000_000));
        // Joining 5.1 s after the start (beat 18.2) with 250 ms to get ready (to 18.7):
        // quarter 7 of the score, at beat 19.
        let e = entry(&l, 4.0, 6_100_000, 250_000);
        assert_eq!((e.quarter, e.host_us), (7, 6_500_000));
        // Exactly on a beat: that beat.
        let e = entry(&l, 4.0, 6_000_000, 0);
        assert_eq!(e.quarter, 6);
    }
}
