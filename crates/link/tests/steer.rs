//! The steering against a session that changes tempo, a score that changes tempo, and a beat
//! that jumps: a performance simulated on the same clock as the session, looked at every
//! 2 ms as `orch play --link` does, stays within 1 ms of the session's beat, and a change is
//! followed within one beat.

use orch_link::{entry, Line, Steer, Step, Timeline};
use orch_perform::{ScoreBeats, TimeMap};

const LOOK_US: i64 = 2_000;
const LOOKAHEAD_US: i64 = 80_000;

/// Quarters of 500 ms for 32 quarters, then of 750 ms (the file slows from 120 to 80 BPM).
fn beats() -> ScoreBeats {
    let mut t = vec![0];
    for q in 1..200u64 {
        let len = if q <= 32 { 500_000 } else { 750_000 };
        t.push(t.last().unwrap() + len);
    }
    ScoreBeats::from_times(t)
}

/// Runs the performance from its entry to `end_us`, the session changed by `change` at each
/// look; returns (host µs, error in µs of the session's beat) at every look after the start.
fn run(session: &mut Line, end_us: i64, change: impl Fn(&mut Line, i64)) -> Vec<(i64, f64)> {
    run_drifting(session, end_us, 0.0, change)
}

/// [`run`], the performer's clock running `drift` (a fraction) faster than the session's.
fn run_drifting(
    session: &mut Line,
    end_us: i64,
    drift: f64,
    change: impl Fn(&mut Line, i64),
) -> Vec<(i64, f64)> {
    let wall = |t: i64| t + (t as f64 * drift) as i64;
    let beats = beats();
    let e = entry(&*session, 4.0, 0, LOOKAHEAD_US);
    let steer = Steer::new(beats.clone(), 4.0, e, LOOKAHEAD_US);
    let mut map = TimeMap::new(wall(e.host_us), steer.factor_at(0, session.bpm).unwrap());
    let mut errors = Vec::new();
    let mut t = 0;
    while t < end_us {
        change(session, t);
        match steer.step(&*session, t, wall(t), &map) {
            Step::Hold => {}
            Step::Tempo(f) => map.change(wall(t), f),
            Step::Jump(s) => map.jump(wall(t + LOOKAHEAD_US), s),
            Step::Stop => break,
        }
        if t >= e.host_us {
            let played = beats.at(map.score(wall(t))).0;
            let asked = session.beat_at(t, 4.0) - e.bar_one;
            errors.push((t, (played - asked) * 60e6 / session.bpm));
        }
        t += LOOK_US;
    }
    errors
}

fn session() -> Line {
    Line {
        bpm: 100.0,
        at_us: 0,
        beat: 0.0,
        playing: true,
        started_beat: 0.0,
    }
}

fn worst(errors: &[(i64, f64)], from: i64, to: i64) -> f64 {
    let w = worst_of(errors, from, to);
    eprintln!("worst from {from} to {to}: {w:.1} µs");
    w
}

fn worst_of(errors: &[(i64, f64)], from: i64, to: i64) -> f64 {
    errors
        .iter()
        .filter(|(t, _)| (from..to).contains(t))
        .map(|(_, e)| e.abs())
        .fold(0.0, f64::max)
}

#[test]
fn the_performance_keeps_the_beat_through_the_files_own_tempo_change() {
    let errors = run(&mut session(), 40_000_000, |_, _| {});
    // Bar one is beat 4 (2.4 s); the file's change at quarter 32 (beat 36, 21.6 s).
    assert!(
        worst(&errors, 0, 40_000_000) < 1_000.0,
        "{}",
        worst(&errors, 0, 40_000_000)
    );
}

#[test]
fn a_peers_tempo_change_is_followed_within_one_beat() {
    let changed_at = 10_000_000;
    let errors = run(&mut session(), 20_000_000, |s, t| {
        if t == changed_at {
            s.change_tempo(t, 130.0);
        }
    });
    let beat_after = changed_at + (60e6 / 130.0) as i64;
    assert!(worst(&errors, 0, changed_at) < 1_000.0);
    assert!(worst(&errors, beat_after, 20_000_000) < 1_000.0);
}

#[test]
fn a_beat_that_jumps_is_jumped_to() {
    let jumped_at = 8_000_000;
    let errors = run(&mut session(), 16_000_000, |s, t| {
        if t == jumped_at {
            // Two sessions met: the beat moves by one and a half.
            s.beat += 1.5;
        }
    });
    let settled = jumped_at + LOOKAHEAD_US + 100_000;
    assert!(
        worst(&errors, settled, 16_000_000) < 1_000.0,
        "{}",
        worst(&errors, settled, 16_000_000)
    );
}

/// Link shares the phase of the beat within a bar, not the count of beats: a host's count may
/// move by a whole bar (seen at a tempo change), and the score goes on where it is.
#[test]
fn a_count_of_beats_moved_by_a_bar_moves_nothing() {
    let moved_at = 8_000_000;
    let errors = run(&mut session(), 16_000_000, |s, t| {
        if t == moved_at {
            s.beat -= 4.0;
        }
    });
    assert!(worst(&errors, 0, moved_at) < 1_000.0);
    // From the move on, the performance stands a bar (4 beats of 600 ms) ahead of the moved
    // count, on the beat.
    let off_a_bar = errors
        .iter()
        .filter(|(t, _)| *t >= moved_at)
        .map(|(_, e)| (e - 2_400_000.0).abs())
        .fold(0.0, f64::max);
    assert!(off_a_bar < 1_000.0, "{off_a_bar:.1} µs");
}

#[test]
fn a_stopped_session_stops_the_performance() {
    let mut s = session();
    let errors = run(&mut s, 20_000_000, |s, t| s.playing = t < 5_000_000);
    assert!(errors.last().unwrap().0 < 5_000_000);
}

/// The performer's clock (Rust's, `CLOCK_MONOTONIC`) and Link's (`CLOCK_MONOTONIC_RAW`) may
/// run apart while NTP slews the one: at 500 ppm, the most NTP slews, the pull keeps the
/// beat (without it the error would grow by half a millisecond a second).
#[test]
fn a_clock_that_runs_apart_is_pulled_back_to_the_beat() {
    let errors = run_drifting(&mut session(), 30_000_000, 500e-6, |_, _| {});
    assert!(worst(&errors, 0, 30_000_000) < 1_000.0);
}
