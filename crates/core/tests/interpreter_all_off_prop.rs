//! Guards the way out: after any byte stream, at any times, under any configuration (guard on
//! or off, either note store), `all_off()` and a flush leave every bit of every board at 0, in
//! the frame and on the boards, and nothing comes back on by itself afterwards (no delayed
//! re-strike survives it).

mod common;

use common::{any_config, run_steps, timed_steps, Rig};
use orch_core::{Duration, GuardConfig, HeldNotes, NotePool, NoteTable};
use proptest::prelude::*;

fn all_off_clears_everything<H: HeldNotes>(mut rig: Rig<H>, steps: &[common::Step]) {
    let end = run_steps(&mut rig, steps, |_| {});
    rig.all_off(end);
    assert_eq!(rig.boards.outputs(0), 0);
    assert_eq!(rig.last, [0; 4], "boards after all_off and flush");
    assert_eq!(rig.robot.frame().all(), &[0; 4], "frame after all_off");
    assert!(!rig.robot.frame().any_dirty());
    assert_eq!(rig.robot.keys_down(), 0);
    assert!((0..61).all(|k| !rig.robot.is_down(k)));
    // Nothing comes back: not at the deadlines, not an hour later.
    let later = end + Duration::from_secs(3600);
    rig.run_until(later);
    rig.tick(later);
    assert_eq!(rig.last, [0; 4], "a key came back on after all_off");
    assert_eq!(rig.robot.keys_down(), 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    #[test]
    fn after_any_stream_all_off_leaves_every_board_at_zero(
        config in any_config(),
        guard_off in any::<bool>(),
        pool in any::<bool>(),
        steps in timed_steps(60),
    ) {
        let config = orch_core::Config {
            guard: if guard_off { GuardConfig::OFF } else { config.guard },
            ..config
        };
        if pool {
            all_off_clears_everything(Rig::<NotePool<8>>::with_store(config), &steps);
        } else {
            all_off_clears_everything(Rig::<NoteTable>::with_store(config), &steps);
        }
    }

    #[test]
    fn after_any_raw_bytes_all_off_leaves_every_board_at_zero(
        bytes in common::byte_stream(300),
    ) {
        let mut rig = Rig::thesis();
        rig.feed(&bytes, common::ms(0));
        rig.all_off(common::ms(1));
        prop_assert_eq!(rig.last, [0; 4]);
        prop_assert_eq!(rig.robot.frame().all(), &[0; 4]);
    }
}
