//! Guards the power budget and the re-strike gap with time: on random streams with random
//! time gaps and any guard limits, the boards never show more than `max_keys_down` fingers
//! down, and a finger that went up never goes down again before `restrike_gap` has passed
//! (checked on the timeline of board writes). Also: the Stats always add up.

mod common;

use common::{any_config, assert_restrike_gap, max_fingers_down, run_steps, timed_steps, Rig};
use orch_core::{Config, Duration, GuardConfig};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    #[test]
    fn keys_down_never_exceed_the_budget(config in any_config(), steps in timed_steps(80)) {
        let max = config.guard.max_keys_down;
        // With dynamics the budget is a current: the keys' duties now, in 4095ths of one key
        // at full power. On/off keys are at full power while down: the same as keys down.
        let on_off = common::is_on_off(&config);
        let mut rig = Rig::new(config);
        let end = run_steps(&mut rig, &steps, |rig| {
            let current: u32 = (0..61).map(|k| rig.robot.key_duty(k).get() as u32).sum();
            assert!(current <= max as u32 * 4095, "current {current}/4095, budget {max}");
            if on_off {
                assert!(rig.fingers_down() <= max as u32, "{} fingers down, budget {max}", rig.fingers_down());
                assert!(rig.robot.keys_down() <= max);
            }
        });
        rig.run_until(end + Duration::from_secs(60));
        if on_off {
            prop_assert!(max_fingers_down(&rig.timeline) <= max as u32);
            prop_assert!(rig.robot.stats().peak_keys_down <= max);
        }
    }

    #[test]
    fn a_released_key_never_strikes_again_before_the_gap(
        config in any_config(),
        steps in timed_steps(80),
    ) {
        let gap = config.guard.restrike_gap.as_micros() as u64;
        let mut rig = Rig::new(config);
        let end = run_steps(&mut rig, &steps, |_| {});
        rig.run_until(end + Duration::from_secs(60));
        assert_restrike_gap(&rig.timeline, gap);
    }

    #[test]
    fn hammered_notes_never_smear_with_the_default_gap(
        notes in prop::collection::vec((0u8..4, 58u8..62, any::<bool>(), 0u64..30_000), 1..150),
    ) {
        // A few notes, on and off on a few channels, far faster than the 60 ms gap.
        let mut rig = Rig::thesis();
        let mut t = 0;
        for (channel, note, on, gap) in notes {
            t += gap;
            let status = if on { 0x90 } else { 0x80 } | channel;
            rig.feed(&[status, note, 100], common::us(t));
        }
        rig.run_until(common::us(t) + Duration::from_secs(60));
        assert_restrike_gap(&rig.timeline, 60_000);
    }

    #[test]
    fn stats_always_add_up(config in any_config(), steps in timed_steps(80)) {
        let mut rig = Rig::new(config);
        let end = run_steps(&mut rig, &steps, |rig| {
            let s = rig.robot.stats();
            // While a strike waits for its gap its note is not counted yet.
            let waiting = s.note_ons - (s.played + s.folded + s.dropped());
            assert!(waiting <= 61, "{s:?}");
        });
        rig.run_until(end + Duration::from_secs(60));
        let s = *rig.robot.stats();
        prop_assert_eq!(s.note_ons, s.played + s.folded + s.dropped(), "{:?}", s);
    }

    #[test]
    fn with_the_guard_at_its_defaults_nothing_exceeds_16_keys(steps in timed_steps(120)) {
        let mut rig = Rig::new(Config { guard: GuardConfig::DEFAULT, ..Config::THESIS });
        let end = run_steps(&mut rig, &steps, |rig| assert!(rig.fingers_down() <= 16));
        rig.run_until(end + Duration::from_secs(60));
        assert_restrike_gap(&rig.timeline, 60_000);
        assert_no_hold(&rig);
    }
}

fn assert_no_hold(rig: &Rig) {
    common::assert_no_hold_longer_than(&rig.timeline, 10_000_000, rig.now);
}
