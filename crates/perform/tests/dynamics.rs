//! Dynamics through the performer: on a robot of PCA9685 boards each note strikes at its
//! velocity's duty, the virtual robot hears it at a loudness and a press delay that duty gives,
//! the planner sends each press early by its key's delay at that strength, and a strike too
//! soft for its key is `dropped.too_soft`. The outcomes still add up.

use orch_perform::{Outcome, Played, ScoreEvent};
use orch_seq::WireBytes;
use orch_sim::{KeyMechanics, MechanicsConfig};

mod common;

/// `(ms, note, velocity)` notes, each 200 ms long → score events.
fn song(notes: &[(u64, u8, u8)]) -> (Vec<ScoreEvent>, usize) {
    let mut v = Vec::new();
    for &(ms, n, vel) in notes {
        v.push(ScoreEvent {
            score_us: ms * 1000,
            bytes: WireBytes::new(&[0x90, n, vel]),
        });
        v.push(ScoreEvent {
            score_us: (ms + 200) * 1000,
            bytes: WireBytes::new(&[0x80, n, 0]),
        });
    }
    v.sort_by_key(|e| e.score_us);
    (v, notes.len())
}

fn play(mechanics: MechanicsConfig, compensation: bool, notes: &[(u64, u8, u8)]) -> Played {
    let (events, n) = song(notes);
    common::render(
        &common::pwm_setup(mechanics, compensation),
        events.into_iter(),
        n,
    )
}

/// Velocities 1, 7, … 127, a note every 300 ms, over a few keys.
fn sweep() -> Vec<(u64, u8, u8)> {
    (1..=127u8)
        .step_by(6)
        .enumerate()
        .map(|(i, v)| (500 + i as u64 * 300, 48 + (i % 5) as u8 * 7, v))
        .collect()
}

#[test]
fn a_velocity_sweep_sounds_in_order_of_loudness_at_the_velocity_asked() {
    let p = play(MechanicsConfig::default(), true, &sweep());
    let mut last = 0;
    for r in &p.records {
        assert!(matches!(r.outcome, Outcome::OnTime { .. }), "{r:?}");
        let heard = r.sounded_velocity.unwrap();
        assert!(heard >= last, "{r:?}");
        assert!(heard.abs_diff(r.velocity) <= 1, "{r:?}");
        last = heard;
    }
    let report = p.report(None);
    assert!(report.adds_up());
    let v = report.velocity_error.unwrap();
    assert!(v.median <= 1 && v.max <= 1, "{v:?}");
}

#[test]
fn compensation_by_velocity_lands_soft_and_loud_notes_alike() {
    let notes = sweep();
    let with = play(MechanicsConfig::default(), true, &notes).report(None);
    assert!(with.adds_up());
    assert_eq!(with.outcomes.on_time, notes.len() as u64, "{with:?}");
    assert!(with.onset_ms.median <= 0.1, "{:?}", with.onset_ms);
    assert!(with.onset_ms.max <= 0.2, "{:?}", with.onset_ms);
    // Without it, each note is late by its write and its press delay at its strike's duty:
    // 30 ms at velocity 1 (45 %), 15 ms at 127, linear in the duty between.
    let without = play(MechanicsConfig::default(), false, &notes);
    let key = KeyMechanics::DEFAULT;
    let write_ms = 56.0 / 1000.0; // one channel's write at 1 MHz
    for r in &without.records {
        let duty = orch_core::Touch::PWM.strike_duty(orch_core::Velocity::from_bits(r.velocity));
        let modelled = key.press_delay_at(duty.get()).as_micros() as f64 / 1000.0 + write_ms;
        let late = r.outcome.error_ms().unwrap();
        assert!(
            (late - modelled).abs() <= 0.01,
            "{r:?}: late {late}, modelled {modelled}"
        );
    }
    let first = without.records[0].outcome.error_ms().unwrap();
    let last = without.records.last().unwrap().outcome.error_ms().unwrap();
    assert!(
        first > 30.0 && last < 15.2,
        "soft {first} ms, loud {last} ms"
    );
}

#[test]
fn a_strike_too_soft_for_its_key_is_dropped_too_soft_and_the_outcomes_add_up() {
    // Middle C (key 24) needs 70 % to sound; the robot's curve starts at 45 %.
    let stiff = KeyMechanics {
        softest: 2867,
        ..KeyMechanics::DEFAULT
    };
    // Velocity 50 strikes at 45 % + 49/126 of 55 % = 66 %: still too soft.
    let notes = [
        (500, 60, 1),
        (1_000, 60, 50),
        (1_500, 60, 127),
        (2_000, 62, 1),
    ];
    let p = play(MechanicsConfig::default().with_key(24, stiff), true, &notes);
    let names: Vec<_> = p.records.iter().map(|r| r.outcome.name()).collect();
    assert_eq!(names, ["too_soft", "too_soft", "on_time", "on_time"]);
    assert_eq!(p.records[0].sounded_velocity, None);
    let r = p.report(None);
    assert_eq!(r.outcomes.dropped.too_soft, 2);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.strikes, 2);
    assert_eq!(r.unmatched, 0);
    // The loud one on the stiff key: full power sounds at 127 whatever the key's softest.
    assert_eq!(p.records[2].sounded_velocity, Some(127));
}

#[test]
fn a_robot_whose_keys_are_louder_than_its_curve_says_reports_the_velocity_error() {
    // Keys that sound already at 30 %: every strike of the 45..100 % curve is louder than
    // asked (velocity 1 sounds at 1 + 126 × 15/70 ≈ 28), by more than 2 steps below about
    // velocity 115.
    let loose = KeyMechanics {
        softest: 1229,
        ..KeyMechanics::DEFAULT
    };
    let p = play(MechanicsConfig::uniform(loose), true, &sweep());
    let v = p.report(None).velocity_error.unwrap();
    assert_eq!(v.softer, 0);
    let over = p
        .records
        .iter()
        .filter(|r| r.sounded_velocity.unwrap() > r.velocity + 2)
        .count() as u64;
    assert!(over >= 15, "{over}");
    assert_eq!(v.louder, over, "{v:?}");
    assert_eq!(v.max, 27, "{v:?}");
    assert!(v.median > 2, "{v:?}");
}
