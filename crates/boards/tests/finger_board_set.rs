//! Four finger boards at 0x21..=0x24 on one mock bus, through `orch_core::FingerBoards`.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::{Error, FingerBoardSet};
use orch_core::{BoardId, FingerBoards, FingerFrame, Layout};

// Datasheet values, typed again here on purpose: a wrong constant in the crate must fail.
const OUTPUT_PORT_0: u8 = 0x02;
const CONFIGURATION_0: u8 = 0x06;
const ALL_OUTPUTS: u8 = 0x00;
// The thesis's boards.
const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];

const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);

fn board(index: u8) -> BoardId {
    BoardId {
        index,
        address: ADDRESSES[index as usize],
    }
}

fn outputs(addr: u8, lo: u8, hi: u8) -> Transaction {
    Transaction::write(addr, vec![OUTPUT_PORT_0, lo, hi])
}

fn init_transactions() -> Vec<Transaction> {
    ADDRESSES
        .iter()
        .flat_map(|&a| {
            [
                outputs(a, 0x00, 0x00),
                Transaction::write(a, vec![CONFIGURATION_0, ALL_OUTPUTS, ALL_OUTPUTS]),
            ]
        })
        .collect()
}

fn set_after_init(then: &[Transaction]) -> FingerBoardSet<Mock, 4> {
    let mut expected = init_transactions();
    expected.extend_from_slice(then);
    let mut set = FingerBoardSet::new(Mock::new(&expected), ADDRESSES);
    set.init().unwrap();
    set
}

#[test]
fn init_zeroes_each_boards_outputs_before_making_its_pins_outputs() {
    let set = set_after_init(&[]);
    for i in 0..4 {
        assert_eq!(set.last_written(i), Some(0));
    }
    set.destroy().done();
}

#[test]
fn init_stops_at_a_board_that_nacks_and_leaves_later_boards_untouched() {
    let mut expected = init_transactions();
    expected.truncate(3);
    expected[2] = expected[2].clone().with_error(NACK); // board 1's zeroing write
    let mut set = FingerBoardSet::new(Mock::new(&expected), ADDRESSES);
    assert_eq!(set.init().unwrap_err(), Error::I2c(NACK));
    assert_eq!(set.last_written(0), Some(0));
    assert_eq!(set.last_written(1), None);
    assert_eq!(set.last_written(2), None);
    set.destroy().done();
}

#[test]
fn single_key_change_is_one_write_to_one_board() {
    // Output 8 of board 2 (0x23) is port 1 bit 0: [0x02, 0x00, 0x01].
    let mut set = set_after_init(&[outputs(0x23, 0x00, 0x01)]);
    set.write_board(board(2), 1 << 8).unwrap();
    set.destroy().done();
}

#[test]
fn unchanged_board_is_not_written_again() {
    let mut set = set_after_init(&[outputs(0x21, 0x05, 0x00)]);
    set.write_board(board(0), 0x0005).unwrap();
    set.write_board(board(0), 0x0005).unwrap();
    set.write_board(board(1), 0x0000).unwrap(); // already 0 since init
    set.destroy().done();
}

#[test]
fn only_the_changed_board_is_written_among_four() {
    let mut set = set_after_init(&[outputs(0x24, 0x00, 0x10), outputs(0x22, 0x01, 0x00)]);
    let frame = [0x0000, 0x0000, 0x0000, 0x1000];
    for (i, &v) in frame.iter().enumerate() {
        set.write_board(board(i as u8), v).unwrap();
    }
    let frame = [0x0000, 0x0001, 0x0000, 0x1000];
    for (i, &v) in frame.iter().enumerate() {
        set.write_board(board(i as u8), v).unwrap();
    }
    set.destroy().done();
}

#[test]
fn nack_surfaces_as_typed_error_and_next_write_retries() {
    let mut set = set_after_init(&[
        outputs(0x22, 0x02, 0x00).with_error(NACK),
        outputs(0x22, 0x02, 0x00),
    ]);
    let err = set.write_board(board(1), 0x0002).unwrap_err();
    assert_eq!(err, Error::I2c(NACK));
    assert!(err.is_nack());
    assert_eq!(set.last_written(1), None);
    // Same value: the cache must not swallow the retry.
    set.write_board(board(1), 0x0002).unwrap();
    assert_eq!(set.last_written(1), Some(0x0002));
    set.destroy().done();
}

#[test]
fn unknown_board_index_is_a_typed_error_without_bus_traffic() {
    let mut set = set_after_init(&[]);
    let id = BoardId {
        index: 4,
        address: 0x25,
    };
    assert_eq!(set.write_board(id, 1).unwrap_err(), Error::UnknownBoard(4));
    assert_eq!(set.init_board(7).unwrap_err(), Error::UnknownBoard(7));
    assert_eq!(set.last_written(4), None);
    set.destroy().done();
}

#[test]
fn address_mismatch_is_a_typed_error_without_bus_traffic() {
    let mut set = set_after_init(&[]);
    let id = BoardId {
        index: 0,
        address: 0x22,
    };
    assert_eq!(
        set.write_board(id, 1).unwrap_err(),
        Error::AddressMismatch {
            index: 0,
            expected: 0x21,
            requested: 0x22
        }
    );
    set.destroy().done();
}

#[test]
fn invalidate_makes_the_next_write_go_out() {
    let mut set = set_after_init(&[outputs(0x21, 0x00, 0x00)]);
    set.invalidate();
    set.write_board(board(0), 0).unwrap();
    set.destroy().done();
}

#[test]
fn release_all_writes_every_board_even_after_a_nack() {
    let mut set = set_after_init(&[
        outputs(0x21, 0x00, 0x00),
        outputs(0x22, 0x00, 0x00).with_error(NACK),
        outputs(0x23, 0x00, 0x00),
        outputs(0x24, 0x00, 0x00),
    ]);
    assert_eq!(set.release_all().unwrap_err(), Error::I2c(NACK));
    assert_eq!(set.last_written(0), Some(0));
    assert_eq!(set.last_written(1), None);
    assert_eq!(set.last_written(3), Some(0));
    set.destroy().done();
}

#[test]
fn core_flush_of_note_76_writes_third_board_0x23_port_1_bit_0() {
    // Note 76 is key 40: board index 2 (0x23), bit 8 by the code's arithmetic.
    let layout = Layout::THESIS;
    let finger = layout.finger(76 - 36).unwrap();
    let mut frame = FingerFrame::<4>::new();
    frame.set(finger.board, finger.bit, true);
    let mut set = set_after_init(&[outputs(0x23, 0x00, 0x01)]);
    assert_eq!(frame.flush(&layout, &mut set).unwrap(), 1);
    set.destroy().done();
}

#[test]
fn destroy_hands_back_the_bus_without_traffic() {
    let set = FingerBoardSet::new(Mock::new(&[]), ADDRESSES);
    assert_eq!(set.addresses(), &ADDRESSES);
    let mut bus = set.destroy();
    bus.done();
}
