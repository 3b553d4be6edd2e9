//! Guards the safety guard's rules, each on the timeline of board writes: the re-strike gap
//! (a repeated note releases, waits, then presses again, never smearing), the power budget
//! (the 17th key is refused), the watchdog (4 s of silence, 300 ms once Active Sensing was
//! seen), the hold limit (10 s, and the key strikes again afterwards), `tick`,
//! `next_deadline`, `all_off`, and the Stats that must add up.

mod common;

use common::{ms, Rig};
use orch_core::{Config, Duration, GuardConfig, Instant, Interpreter, Recording};

#[test]
fn the_defaults_are_the_specs() {
    let g = GuardConfig::default();
    assert!(g.enabled, "the guard is on by default");
    assert_eq!(g.max_hold, Some(Duration::from_secs(10)));
    assert_eq!(g.max_keys_down, 16);
    assert_eq!(g.restrike_gap, Duration::from_millis(60));
    assert_eq!(g.watchdog, Some(Duration::from_secs(4)));
    assert_eq!(Config::THESIS.guard, g);
    assert_eq!(
        orch_core::ACTIVE_SENSING_TIMEOUT,
        Duration::from_millis(300)
    );
}

#[test]
fn a_repeated_note_releases_waits_the_gap_then_presses_again() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(10));
    rig.feed(&[0x90, 60, 100], ms(20)); // 10 ms after the release: too soon
    assert!(!rig.note_down(60), "must not strike again before the gap");
    rig.run_until(ms(500));
    assert_eq!(
        rig.edges_of(60),
        vec![(ms(0), true), (ms(10), false), (ms(70), true)],
        "released at 10 ms, struck again at 10 + 60 ms"
    );
    assert_eq!(rig.robot.stats().restrikes_delayed, 1);
}

#[test]
fn a_note_on_for_a_note_already_down_lifts_the_key_first() {
    // No Note-Off between: the key must still go up and rest, not stay down (smear).
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x90, 60, 100], ms(100));
    rig.run_until(ms(500));
    assert_eq!(
        rig.edges_of(60),
        vec![(ms(0), true), (ms(100), false), (ms(160), true)]
    );
}

#[test]
fn a_repeated_note_after_the_gap_strikes_at_once() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0x90, 60, 100], ms(160));
    assert_eq!(
        rig.edges_of(60),
        vec![(ms(0), true), (ms(100), false), (ms(160), true)]
    );
}

#[test]
fn a_repeated_note_shorter_than_the_gap_still_sounds_after_it() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(10));
    rig.feed(&[0x90, 60, 100], ms(20));
    rig.feed(&[0x80, 60, 0], ms(30)); // released before its delayed strike
    rig.run_until(ms(500));
    let edges = rig.edges_of(60);
    assert_eq!(
        &edges[..3],
        &[(ms(0), true), (ms(10), false), (ms(70), true)]
    );
    assert_eq!(edges.len(), 4, "{edges:?}");
    assert!(!edges[3].1);
    let press = edges[3].0.saturating_since(edges[2].0);
    assert_eq!(press, 20_000, "held for min_press");
    assert_eq!(rig.robot.stats().dropped_cancelled, 0);
}

#[test]
fn many_fast_repeats_never_smear() {
    // A note hammered every 5 ms for 400 ms: every strike is separated by at least 60 ms up.
    let mut rig = Rig::patient();
    for i in 0..80u64 {
        let status = if i % 2 == 0 { 0x90 } else { 0x80 };
        rig.feed(&[status, 60, 100], ms(i * 5));
    }
    rig.run_until(ms(2_000));
    common::assert_restrike_gap(&rig.timeline, 60_000);
    let strikes = rig.edges_of(60).iter().filter(|e| e.1).count();
    assert!(strikes >= 5, "it keeps playing: {strikes} strikes");
}

#[test]
fn the_power_budget_refuses_the_17th_key() {
    let mut rig = Rig::thesis();
    for i in 0..16u8 {
        rig.feed(&[0x90, 40 + i, 100], ms(0));
    }
    assert_eq!(rig.fingers_down(), 16);
    rig.feed(&[0x90, 80, 100], ms(100));
    assert!(!rig.note_down(80), "the new note is refused");
    assert_eq!(rig.fingers_down(), 16);
    assert!(
        (40..56).all(|n| rig.note_down(n)),
        "keys already down are never cut"
    );
    assert_eq!(rig.robot.stats().dropped_power, 1);
    // The refused note's Note-Off is harmless, and once a key is free a new one plays.
    rig.feed(&[0x80, 80, 0, 0x80, 40, 0], ms(200));
    rig.feed(&[0x90, 81, 100], ms(300));
    assert!(rig.note_down(81));
    assert_eq!(rig.fingers_down(), 16);
    // A second note on a key already down is not a 17th key.
    rig.feed(&[0x91, 41, 100], ms(400));
    assert_eq!(rig.robot.stats().dropped_power, 1);
}

#[test]
fn the_power_budget_is_configurable() {
    let mut rig = Rig::with_guard(GuardConfig {
        max_keys_down: 2,
        ..GuardConfig::DEFAULT
    });
    rig.feed(&[0x90, 60, 1, 61, 1, 62, 1], ms(0));
    assert_eq!(rig.fingers_down(), 2);
    assert!(!rig.note_down(62));
}

#[test]
fn the_watchdog_releases_everything_after_4_s_without_a_byte() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100, 0x91, 70, 100], ms(0));
    assert_eq!(rig.robot.next_deadline(), Some(ms(4_000)));
    rig.run_until(ms(20_000));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(4_000), false)]);
    assert_eq!(rig.edges_of(70), vec![(ms(0), true), (ms(4_000), false)]);
    assert_eq!(rig.robot.stats().cut_by_watchdog, 2);
}

#[test]
fn the_watchdog_counts_from_the_last_byte_of_any_kind() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0xF8], ms(3_000)); // a clock byte: the sender is alive
    rig.feed(&[0xF8], ms(6_000));
    rig.feed(&[0xF9], ms(9_000)); // even an undefined byte
    rig.run_until(ms(9_000));
    assert!(rig.note_down(60), "bytes kept arriving");
    rig.run_until(ms(20_000));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(10_000), false)]);
    assert_eq!(rig.robot.stats().cut_by_watchdog, 0);
    assert_eq!(rig.robot.stats().cut_by_hold_limit, 1);
}

#[test]
fn the_watchdog_stays_quiet_while_active_sensing_arrives_every_200_ms() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100], ms(0));
    for t in (200..=6_000).step_by(200) {
        rig.feed(&[0xFE], ms(t));
    }
    assert!(
        rig.note_down(60),
        "6 s of active sensing keeps the key down"
    );
    // Active sensing stops: the specification's 300 ms applies.
    rig.run_until(ms(20_000));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(6_300), false)]);
    assert_eq!(rig.robot.stats().cut_by_watchdog, 1);
}

#[test]
fn one_active_sensing_byte_arms_the_300_ms_rule() {
    let mut rig = Rig::thesis();
    rig.feed(&[0xFE], ms(0));
    rig.feed(&[0x90, 60, 100], ms(100));
    rig.feed(&[0x80, 60, 0, 0x90, 62, 100], ms(300)); // a byte is a byte
    assert_eq!(rig.robot.next_deadline(), Some(ms(600)));
    rig.run_until(ms(5_000));
    assert_eq!(rig.edges_of(62), vec![(ms(300), true), (ms(600), false)]);
}

#[test]
fn without_active_sensing_a_long_silence_below_4_s_keeps_keys_down() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.run_until(ms(3_999));
    assert!(rig.note_down(60));
}

#[test]
fn the_hold_limit_cuts_at_10_s_and_the_key_strikes_again_afterwards() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100], ms(0));
    for t in (1_000..=10_000).step_by(1_000) {
        rig.feed(&[0xF8], ms(t));
    }
    assert!(!rig.note_down(60));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(10_000), false)]);
    assert_eq!(rig.robot.stats().cut_by_hold_limit, 1);
    // Its Note-Off is harmless; the next Note-On strikes again (after the gap).
    rig.feed(&[0x80, 60, 0], ms(10_020));
    rig.feed(&[0x90, 60, 100], ms(10_030));
    rig.run_until(ms(10_200));
    assert!(rig.note_down(60));
    assert_eq!(rig.edges_of(60)[2], (ms(10_060), true));
    rig.feed(&[0x80, 60, 0], ms(10_300));
    assert!(!rig.note_down(60));
}

#[test]
fn the_hold_limit_is_measured_per_key_from_its_strike() {
    let mut rig = Rig::with_guard(GuardConfig {
        max_hold: Some(Duration::from_millis(50)),
        ..GuardConfig::DEFAULT
    });
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x90, 62, 100], ms(30));
    rig.run_until(ms(1_000));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(50), false)]);
    assert_eq!(rig.edges_of(62), vec![(ms(30), true), (ms(80), false)]);
}

#[test]
fn tick_fires_the_time_rules_without_input() {
    // Without `next_deadline`: one late tick does it.
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<8>::new();
    robot.feed_slice(&[0x90, 60, 100], ms(0));
    robot.flush(&mut boards).unwrap();
    robot.tick(ms(3_000));
    assert!(robot.is_down(24));
    robot.tick(ms(4_500));
    assert!(!robot.is_down(24));
    robot.flush(&mut boards).unwrap();
    assert_eq!(boards.outputs(1), 0);
}

#[test]
fn next_deadline_never_misses_a_timer_and_settles_to_none_when_idle() {
    let mut rig = Rig::patient();
    assert_eq!(rig.robot.next_deadline(), None, "idle from the start");
    rig.feed(&[0x90, 60, 100], ms(0));
    assert_eq!(rig.robot.next_deadline(), Some(ms(4_000)), "the watchdog");
    rig.feed(&[0x80, 60, 0], ms(100));
    // Nothing is down and nothing waits. The answer may be early (documented), but ticking
    // at it does nothing, and afterwards there is no deadline.
    if let Some(d) = rig.robot.next_deadline() {
        let edges = rig.timeline.len();
        rig.tick(d);
        assert_eq!(
            rig.timeline.len(),
            edges,
            "a spurious deadline must do nothing"
        );
    }
    assert_eq!(rig.robot.next_deadline(), None);
    let now = rig.now;
    rig.feed(&[0x90, 60, 100], now);
    rig.feed(
        &[0x80, 60, 0, 0x90, 60, 100],
        now + Duration::from_millis(20),
    );
    // The delayed re-strike is due 60 ms after the release.
    let restrike = now + Duration::from_millis(80);
    let next = rig.robot.next_deadline().unwrap();
    assert!(
        next <= restrike,
        "{next:?} is later than the re-strike at {restrike:?}"
    );
    rig.run_until(restrike);
    assert!(rig.note_down(60));
    let next = rig.robot.next_deadline().unwrap();
    assert!(next > restrike, "no deadline in the past after ticking it");
    // With the guard off there are no timers.
    let mut off = Rig::with_guard(GuardConfig::OFF);
    off.feed(&[0x90, 60, 100], ms(0));
    assert_eq!(off.robot.next_deadline(), None);
    off.tick(ms(3_600_000));
    assert!(off.note_down(60), "guard off: the bare mapping");
}

#[test]
fn all_off_releases_everything_and_cancels_waiting_strikes() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100, 62, 100, 0x95, 24, 100], ms(0));
    rig.feed(&[0x80, 60, 0, 0x90, 60, 100], ms(10)); // 60 now waits for its gap
    rig.all_off(ms(20));
    assert_eq!(rig.fingers_down(), 0);
    assert_eq!(rig.robot.keys_down(), 0);
    assert_eq!(rig.robot.stats().dropped_stopped, 1);
    // Afterwards everything plays again, respecting the gap from the all-off.
    rig.feed(&[0x90, 62, 100], ms(30));
    rig.run_until(ms(200));
    assert_eq!(rig.edges_of(62).last(), Some(&(ms(80), true)));
    assert!(
        !rig.note_down(60),
        "the cancelled re-strike must not come back"
    );
    rig.all_off(ms(300));
    rig.run_until(ms(20_000));
    rig.tick(ms(20_000));
    assert_eq!(rig.fingers_down(), 0);
}

#[test]
fn stats_add_up() {
    let mut rig = Rig::new(Config {
        channels: orch_core::ChannelMask(0x00FF),
        guard: GuardConfig {
            max_keys_down: 4,
            ..GuardConfig::DEFAULT
        },
        ..Config::THESIS
    });
    let t = |i: u64| Instant::from_micros(i * 7_000);
    let bytes: [&[u8]; 12] = [
        &[0x90, 60, 100, 61, 100, 62, 100],
        &[0x99, 60, 100],           // masked channel 10: percussion
        &[0x90, 24, 100, 100, 100], // folded twice
        &[0x90, 63, 100, 64, 100],  // over the budget
        &[0x80, 60, 0],
        &[0x90, 60, 100],                // delayed re-strike
        &[0x90, 0, 0],                   // not a Note-On
        &[0xFF],                         // reset: cancels the delayed one
        &[0x91, 70, 100, 0x92, 70, 100], // two on one key
        &[0x90, 70, 100],
        &[0xB1, 123, 0],
        &[0x90, 60, 100, 60, 100], // repeated
    ];
    for (i, b) in bytes.iter().enumerate() {
        rig.feed(b, t(i as u64));
    }
    rig.run_until(ms(60_000));
    let s = *rig.robot.stats();
    assert_eq!(s.note_ons, 14);
    assert_eq!(s.note_ons, s.played + s.folded + s.dropped(), "{s:?}");
    assert_eq!((s.dropped_channel, s.dropped_percussion), (0, 1));
    assert!(s.dropped_power >= 1, "{s:?}");
    assert!(s.folded >= 1, "{s:?}");
    assert!(s.peak_keys_down <= 4);
}

/// Regression (found by `guard_hold_limit_prop`): with a zero re-strike gap, a key released
/// and struck again at the same instant never went up on the boards (the frame went 1, 0, 1
/// between two flushes), yet its hold limit restarted from the re-strike. A note repeated
/// faster than the hold limit then held its solenoid on for ever.
#[test]
fn with_a_zero_gap_a_repeated_note_still_lifts_the_key_and_the_hold_limit_holds() {
    let mut rig = Rig::with_guard(GuardConfig {
        restrike_gap: Duration::ZERO,
        max_hold: Some(Duration::from_millis(50)),
        ..GuardConfig::DEFAULT
    });
    for t in (0..=400).step_by(40) {
        rig.feed(&[0x91, 37, 1], ms(t));
    }
    rig.run_until(ms(1_000));
    common::assert_no_hold_longer_than(&rig.timeline, 50_000, rig.now);
    let releases = rig.edges_of(37).iter().filter(|e| !e.1).count();
    assert!(
        releases >= 10,
        "every repeat lifts the key: {:?}",
        rig.edges_of(37)
    );
}

/// Regression: the hold limit cut a key inside `feed` (which ticks first) and a Note-On in the
/// same call struck it again at once, so the cut never reached the boards.
#[test]
fn a_key_cut_by_the_hold_limit_does_not_strike_again_in_the_same_instant() {
    let config = Config {
        guard: GuardConfig {
            restrike_gap: Duration::ZERO,
            max_hold: Some(Duration::from_millis(50)),
            ..GuardConfig::DEFAULT
        },
        ..Config::THESIS
    };
    let mut robot: Interpreter = Interpreter::new(config).unwrap();
    let mut boards = Recording::<8>::new();
    robot.feed_slice(&[0x90, 60, 100], ms(0));
    robot.flush(&mut boards).unwrap();
    assert_eq!(boards.outputs(1), 1 << 8);
    // No tick in between: the byte at 50 ms finds the key at its limit.
    robot.feed_slice(&[0x90, 60, 100], ms(50));
    robot.flush(&mut boards).unwrap();
    assert_eq!(boards.outputs(1), 0, "the cut must reach the boards");
    let next = robot.next_deadline().unwrap();
    assert!(next > ms(50));
    robot.tick(next);
    robot.flush(&mut boards).unwrap();
    assert_eq!(
        boards.outputs(1),
        1 << 8,
        "and the new note strikes after it"
    );
}

/// Regression: per-key times are 32-bit µs, clamped as the clock moves. A key that had rested
/// for 107 minutes was taken as rested for only 18 (its age wrapped across a long silence), so
/// with a 30-minute re-strike gap (the longest allowed) its next note was held back 12 more
/// minutes.
#[test]
fn a_long_rest_is_not_mistaken_for_a_short_one_across_the_32_bit_wrap() {
    let config = Config {
        guard: GuardConfig {
            restrike_gap: orch_core::MAX_LIMIT,
            ..GuardConfig::DEFAULT
        },
        ..Config::THESIS
    };
    let mut robot: Interpreter = Interpreter::new(config).unwrap();
    let us = Instant::from_micros;
    robot.feed_slice(&[0x90, 60, 100], us(1));
    robot.feed_slice(&[0x80, 60, 0], us(2));
    let q = 1u64 << 30;
    for t in [q - 1, 2 * q - 1, 3 * q, 4 * q - 1] {
        robot.tick(us(t));
    }
    let later = 4 * q - 1 + (1 << 31) - 1; // 107 minutes after the release
    robot.feed_slice(&[0x90, 60, 100], us(later));
    assert!(
        robot.is_down(24),
        "rested far longer than the gap: strikes at once"
    );
    assert_eq!(robot.stats().restrikes_delayed, 0);
}
