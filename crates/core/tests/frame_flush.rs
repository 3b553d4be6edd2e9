//! Guards the output side: the frame is B boards × 16 bits with a dirty flag per board, and
//! a flush writes each changed board once, in board order, through `FingerBoards` (here the
//! `Recording` double). A key change costs exactly one write, to one board; a board that
//! fails stays dirty and is written again by the next flush.
//! (The original rewrote all four boards in a busy loop, two transactions each.)

mod common;

use common::ms;
use orch_core::{
    BoardId, Config, FingerFrame, FlushError, GuardConfig, Instant, Interpreter, Layout, Nack,
    Recording, Write,
};

fn writes<const N: usize>(r: &Recording<N>) -> Vec<(u8, u8, u16)> {
    r.writes()
        .map(|w| (w.board.index, w.board.address, w.outputs))
        .collect()
}

#[test]
fn a_key_change_is_one_write_to_one_board() {
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<16>::new();
    robot.feed_slice(&[0x90, 60, 100], ms(0));
    assert_eq!(robot.flush(&mut boards), Ok(1));
    assert_eq!(writes(&boards), vec![(1, 0x22, 1 << 8)]);
    boards.clear();
    // Nothing changed: nothing written.
    assert_eq!(robot.flush(&mut boards), Ok(0));
    assert!(boards.is_empty());
    robot.feed_slice(&[0x80, 60, 0], ms(100));
    robot.flush(&mut boards).unwrap();
    assert_eq!(writes(&boards), vec![(1, 0x22, 0)]);
}

#[test]
fn changes_on_several_boards_are_one_write_each_in_board_order() {
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<16>::new();
    // Keys 50 (board 3), 0 and 1 (board 0), 20 (board 1).
    robot.feed_slice(&[0x90, 86, 1, 36, 1, 37, 1, 56, 1], ms(0));
    assert!(robot.frame().is_dirty(0) && robot.frame().is_dirty(1) && robot.frame().is_dirty(3));
    assert!(!robot.frame().is_dirty(2));
    assert_eq!(robot.flush(&mut boards), Ok(3));
    assert_eq!(
        writes(&boards),
        vec![(0, 0x21, 0b11), (1, 0x22, 1 << 4), (3, 0x24, 1 << 2)]
    );
    assert!(!robot.frame().any_dirty());
}

#[test]
fn a_key_down_and_up_between_two_flushes_costs_no_write_without_the_guard() {
    let mut robot: Interpreter = Interpreter::new(Config {
        guard: GuardConfig::OFF,
        ..Config::THESIS
    })
    .unwrap();
    let mut boards = Recording::<16>::new();
    robot.feed_slice(&[0x90, 60, 100, 0x80, 60, 0], ms(0));
    assert!(!robot.frame().any_dirty());
    assert_eq!(robot.flush(&mut boards), Ok(0));
    assert!(boards.is_empty());
}

#[test]
fn a_zero_length_note_still_strikes_for_min_press_with_the_guard() {
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<16>::new();
    robot.feed_slice(&[0x90, 60, 100, 0x80, 60, 0], ms(0));
    assert_eq!(robot.flush(&mut boards), Ok(1));
    assert_eq!(boards.outputs(1), 1 << 8);
    let min_press = GuardConfig::DEFAULT.min_press.as_micros() as u64;
    assert_eq!(robot.next_deadline(), Some(Instant::from_micros(min_press)));
    robot.tick(Instant::from_micros(min_press - 1));
    assert_eq!(robot.flush(&mut boards), Ok(0));
    robot.tick(Instant::from_micros(min_press));
    assert_eq!(robot.flush(&mut boards), Ok(1));
    assert_eq!(boards.outputs(1), 0);
}

#[test]
fn a_failed_board_stays_dirty_and_is_written_by_the_next_flush() {
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<16>::new();
    robot.feed_slice(&[0x90, 36, 1, 60, 1, 90, 1], ms(0));
    boards.fail(Some(0x22));
    let err = robot.flush(&mut boards).unwrap_err();
    assert_eq!(
        err,
        FlushError {
            board: BoardId {
                index: 1,
                address: 0x22
            },
            error: Nack(0x22)
        }
    );
    // Board 0 went out; board 1 failed; board 3 was not tried.
    assert_eq!(writes(&boards), vec![(0, 0x21, 1)]);
    assert!(!robot.frame().is_dirty(0));
    assert!(robot.frame().is_dirty(1) && robot.frame().is_dirty(3));
    boards.fail(None);
    boards.clear();
    assert_eq!(robot.flush(&mut boards), Ok(2));
    assert_eq!(writes(&boards), vec![(1, 0x22, 1 << 8), (3, 0x24, 1 << 6)]);
}

#[test]
fn invalidate_makes_every_board_be_written_again() {
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<16>::new();
    robot.feed_slice(&[0x90, 60, 100], ms(0));
    robot.flush(&mut boards).unwrap();
    boards.clear();
    robot.frame_mut().invalidate();
    assert_eq!(robot.flush(&mut boards), Ok(4));
    assert_eq!(
        writes(&boards),
        vec![(0, 0x21, 0), (1, 0x22, 1 << 8), (2, 0x23, 0), (3, 0x24, 0)]
    );
}

#[test]
fn the_frame_on_its_own() {
    let mut frame = FingerFrame::<2>::new();
    assert!(!frame.any_dirty());
    frame.set(1, 15, true);
    frame.set(1, 0, true);
    frame.set(1, 0, false);
    assert_eq!(frame.all(), &[0, 0x8000]);
    assert!(frame.is_dirty(1) && !frame.is_dirty(0));
    let layout = Layout::<2>::sequential([0x40, 0x41], 32);
    let mut boards = Recording::<4>::new();
    assert_eq!(frame.flush(&layout, &mut boards), Ok(1));
    assert_eq!(
        boards.writes().collect::<Vec<Write>>(),
        vec![Write {
            board: BoardId {
                index: 1,
                address: 0x41
            },
            outputs: 0x8000,
            duties: None,
        }]
    );
    frame.clear();
    assert!(frame.is_dirty(1));
}

/// `touched` says whether a flush may have anything to write: a firmware checks it after
/// every message instead of comparing every board.
#[test]
fn touched_says_whether_a_flush_may_write() {
    let layout = Layout::<16>::sequential(core::array::from_fn(|i| 0x20 + i as u8), 256);
    let mut frame = FingerFrame::<16>::new();
    let mut boards = Recording::<8>::new();
    assert!(!frame.touched(), "a new frame");
    frame.set(15, 3, true);
    assert!(frame.touched());
    assert_eq!(frame.flush(&layout, &mut boards), Ok(1));
    assert!(!frame.touched(), "flushed");
    // Down and up again: touched, but nothing to write.
    frame.set(2, 0, true);
    frame.set(2, 0, false);
    assert!(frame.touched() && !frame.any_dirty());
    assert_eq!(frame.flush(&layout, &mut boards), Ok(0));
    assert!(!frame.touched());
    frame.invalidate();
    assert!(frame.touched(), "invalidated: every board to be written");
    assert_eq!(frame.flush(&layout, &mut boards), Ok(16));
    frame.clear();
    assert!(frame.touched(), "cleared");
    assert_eq!(
        frame.flush(&layout, &mut boards),
        Ok(1),
        "board 15 goes off"
    );
}
