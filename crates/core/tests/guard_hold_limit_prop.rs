//! Guards the hold limit with time: random streams with random time gaps, ticking at random
//! points and at every `next_deadline()`, under any configuration (sustain on, watchdog off,
//! …). No finger is ever down longer than `max_hold`: read from the timeline of board writes, a
//! bit that goes to 1 at t1 goes back to 0 by t1 + max_hold, checked after every step.

mod common;

use common::{any_config, assert_no_hold_longer_than, run_steps, timed_steps, Rig};
use orch_core::{Config, Duration, GuardConfig};
use proptest::prelude::*;

/// Checks, at the rig's current time, that no finger on the boards has been down longer than
/// `limit_us`.
fn no_finger_older_than(rig: &Rig, limit_us: u64) {
    let mut since = std::collections::HashMap::new();
    for e in &rig.timeline {
        if e.on {
            since.insert((e.board, e.bit), e.t);
        } else {
            since.remove(&(e.board, e.bit));
        }
    }
    for ((board, bit), t1) in since {
        let held = rig.now.saturating_since(t1);
        assert!(
            held <= limit_us,
            "at {:?}: board {board} bit {bit} down since {t1:?} ({held} µs > {limit_us} µs)",
            rig.now
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    #[test]
    fn no_key_is_down_longer_than_a_50_ms_hold_limit(
        config in any_config(),
        steps in timed_steps(80),
    ) {
        let hold = Duration::from_millis(50);
        let config = common::fit_strike(Config {
            guard: GuardConfig { max_hold: Some(hold), ..config.guard },
            ..config
        }, Some(hold));
        let limit = hold.as_micros() as u64;
        let mut rig = Rig::new(config);
        let end = run_steps(&mut rig, &steps, |rig| no_finger_older_than(rig, limit));
        // Let every timer run out.
        let later = end + Duration::from_secs(60);
        rig.run_until(later);
        no_finger_older_than(&rig, limit);
        assert_no_hold_longer_than(&rig.timeline, limit, rig.now);
        prop_assert_eq!(rig.fingers_down(), 0, "an hour… a minute later everything is up");
    }

    #[test]
    fn no_key_is_down_longer_than_any_hold_limit(
        config in any_config(),
        steps in timed_steps(80),
    ) {
        let Some(hold) = config.guard.max_hold else { return Ok(()) };
        let limit = hold.as_micros() as u64;
        let mut rig = Rig::new(config);
        let end = run_steps(&mut rig, &steps, |rig| no_finger_older_than(rig, limit));
        rig.run_until(end + Duration::from_secs(60));
        assert_no_hold_longer_than(&rig.timeline, limit, rig.now);
    }

    #[test]
    fn with_the_default_10_s_limit_a_note_never_released_is_cut_at_10_s(
        note in 0u8..128,
        channel in 0u8..16,
        clock_every_ms in 100u64..3_000,
    ) {
        // Bytes keep arriving (so the watchdog does not act first), the Note-Off never comes.
        let mut rig = Rig::thesis();
        rig.feed(&[0x90 | channel, note, 100], common::ms(0));
        let mut t = 0;
        while t < 12_000 {
            t += clock_every_ms;
            rig.feed(&[0xF8], common::ms(t));
        }
        let key = common::fold(note);
        prop_assert_eq!(rig.edges_of(key), vec![(common::ms(0), true), (common::ms(10_000), false)]);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Per-key times are kept in 32 bits of µs (71 minutes); the limits must hold across
    /// silences of any length, including ones past the wrap.
    #[test]
    fn the_limits_hold_across_long_silences_and_clock_wraps(
        config in any_config(),
        steps in prop::collection::vec(
            (
                prop_oneof![
                    2 => 0u64..200_000,
                    1 => (1u64 << 30) - 5_000_000..(1u64 << 30) + 5_000_000,
                    1 => (1u64 << 31) - 5_000_000..(1u64 << 31) + 5_000_000,
                    1 => (1u64 << 32) - 5_000_000..(1u64 << 32) + 5_000_000,
                    1 => 0u64..(1u64 << 34),
                ],
                prop::option::weighted(0.9, common::musical_chunk()),
            )
                .prop_map(|(gap, bytes)| common::Step { gap, bytes }),
            0..40,
        ),
    ) {
        let hold = config.guard.max_hold;
        let gap = config.guard.restrike_gap.as_micros() as u64;
        let mut rig = Rig::new(config);
        let end = run_steps(&mut rig, &steps, |rig| {
            if let Some(hold) = hold {
                no_finger_older_than(rig, hold.as_micros() as u64);
            }
        });
        rig.run_until(end + Duration::from_secs(60));
        if let Some(hold) = hold {
            assert_no_hold_longer_than(&rig.timeline, hold.as_micros() as u64, rig.now);
        }
        common::assert_restrike_gap(&rig.timeline, gap);
    }
}
