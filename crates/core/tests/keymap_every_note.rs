//! Guards the key map: every MIDI note 0..=127 lands on the board and bit the spec gives
//! (fold by octaves into 36..=96, key k = note − 36 on board k / 16, bit k % 16, boards
//! 0x21..=0x24), under both the Fold and the Drop policy, with the guard off and on; under Drop,
//! notes outside 36..=96 write nothing. Includes the original's off-by-one (note 96 must be on
//! board 0x24 bit 12, not folded to 84) and the thesis's note 76 (board 0x23, bit 8).

mod common;

use common::{fold, ms, Rig};
use orch_core::{Config, GuardConfig, OutOfRange, Recording};

const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];

/// The board index and bit a note must land on under `policy`, from the spec alone.
fn expected(note: u8, policy: OutOfRange) -> Option<(u8, u8)> {
    let n = match policy {
        OutOfRange::Fold => fold(note),
        OutOfRange::Drop if (36..=96).contains(&note) => note,
        OutOfRange::Drop => return None,
    };
    let k = n - 36;
    Some((k / 16, k % 16))
}

/// Plays `note` alone into a fresh robot; returns the writes of the Note-On and of its
/// Note-Off, as (address, board index, outputs).
fn play(note: u8, policy: OutOfRange, guard: GuardConfig) -> [Vec<(u8, u8, u16)>; 2] {
    let mut robot = orch_core::Interpreter::<4, 61>::new(Config {
        out_of_range: policy,
        guard,
        ..Config::THESIS
    })
    .unwrap();
    let mut writes = [Vec::new(), Vec::new()];
    for (i, (bytes, t)) in [([0x90, note, 0x64], ms(0)), ([0x80, note, 0x00], ms(500))]
        .into_iter()
        .enumerate()
    {
        let mut boards = Recording::<8>::new();
        robot.feed_slice(&bytes, t);
        robot.flush(&mut boards).unwrap();
        writes[i] = boards
            .writes()
            .map(|w| (w.board.address, w.board.index, w.outputs))
            .collect();
    }
    writes
}

#[test]
fn every_note_lands_on_its_board_and_bit_under_every_policy_and_guard() {
    for policy in [OutOfRange::Fold, OutOfRange::Drop] {
        for guard in [GuardConfig::OFF, GuardConfig::DEFAULT] {
            for note in 0..=127u8 {
                let [on, off] = play(note, policy, guard);
                let context = format!("note {note}, {policy:?}, guard on: {}", guard.enabled);
                match expected(note, policy) {
                    Some((board, bit)) => {
                        assert_eq!(
                            on,
                            vec![(ADDRESSES[board as usize], board, 1u16 << bit)],
                            "Note-On, {context}"
                        );
                        assert_eq!(
                            off,
                            vec![(ADDRESSES[board as usize], board, 0)],
                            "Note-Off, {context}"
                        );
                    }
                    None => {
                        assert!(on.is_empty(), "no write expected: {context}: {on:?}");
                        assert!(off.is_empty(), "no write expected: {context}: {off:?}");
                    }
                }
            }
        }
    }
}

#[test]
fn note_96_is_the_top_key_on_board_0x24_bit_12_not_folded_to_84() {
    for policy in [OutOfRange::Fold, OutOfRange::Drop] {
        let [on, _] = play(96, policy, GuardConfig::DEFAULT);
        assert_eq!(on, vec![(0x24, 3, 1 << 12)], "{policy:?}");
    }
    // 84 (where the original put 96) is another key: key 48, board 0x24 bit 0.
    let [on, _] = play(84, OutOfRange::Fold, GuardConfig::DEFAULT);
    assert_eq!(on, vec![(0x24, 3, 1 << 0)]);
}

#[test]
fn note_0_folds_to_36_on_board_0x21_bit_0() {
    let [on, _] = play(0, OutOfRange::Fold, GuardConfig::DEFAULT);
    assert_eq!(on, vec![(0x21, 0, 1 << 0)]);
    let [on, _] = play(36, OutOfRange::Fold, GuardConfig::DEFAULT);
    assert_eq!(on, vec![(0x21, 0, 1 << 0)]);
}

#[test]
fn note_127_folds_to_91_key_55_on_board_0x24_bit_7() {
    let [on, _] = play(127, OutOfRange::Fold, GuardConfig::DEFAULT);
    assert_eq!(on, vec![(0x24, 3, 1 << 7)]);
    let [on, _] = play(91, OutOfRange::Fold, GuardConfig::DEFAULT);
    assert_eq!(on, vec![(0x24, 3, 1 << 7)]);
}

#[test]
fn note_76_is_board_0x23_bit_8_as_the_code_computes() {
    // The thesis text says "the fifth finger of the third board"; the code's arithmetic (the
    // default) gives bit 8 of the third board (index 2, 0x23), on port 1.
    let [on, _] = play(76, OutOfRange::Fold, GuardConfig::DEFAULT);
    assert_eq!(on, vec![(0x23, 2, 1 << 8)]);
}

#[test]
fn every_key_of_the_keyboard_has_its_own_finger() {
    // 61 keys, 61 distinct (board, bit) pairs, 16/16/16/13 per board.
    let mut rig = Rig::with_guard(GuardConfig::UNLIMITED);
    for note in 36..=96u8 {
        rig.feed(&[0x90, note, 1], ms(0));
    }
    assert_eq!(rig.last, [0xFFFF, 0xFFFF, 0xFFFF, 0x1FFF]);
    assert_eq!(rig.fingers_down(), 61);
}

#[test]
fn under_drop_out_of_range_notes_do_nothing_and_are_counted() {
    let mut rig = common::Rig::new(Config {
        out_of_range: OutOfRange::Drop,
        ..Config::THESIS
    });
    rig.feed(&[0x90, 35, 100, 97, 100, 0, 100, 127, 100], ms(0));
    assert_eq!(rig.writes, 0);
    assert_eq!(rig.robot.stats().dropped_range, 4);
    assert_eq!(rig.robot.stats().note_ons, 4);
}

#[test]
fn under_fold_folded_notes_are_counted_with_their_octaves() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 24, 100], ms(0)); // +1 octave
    rig.feed(&[0x90, 127, 100], ms(1)); // −3 octaves
    rig.feed(&[0x90, 60, 100], ms(2)); // in range
    let s = rig.robot.stats();
    assert_eq!((s.folded, s.played, s.folded_octaves), (2, 1, 4));
}
