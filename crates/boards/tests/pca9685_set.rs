//! Four PCA9685 boards at 0x40..=0x43 on one mock bus.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::{Error, Pca9685Set};

// Data sheet values, typed again here on purpose.
const MODE1: u8 = 0x00;
const MODE2: u8 = 0x01;
const ALL_LED_OFF_H: u8 = 0xFD;
const PRE_SCALE: u8 = 0xFE;
const AI: u8 = 0x20;
const SLEEP: u8 = 0x10;
const OUTDRV: u8 = 0x04;
const FULL: u8 = 0x10;
const ADDRESSES: [u8; 4] = [0x40, 0x41, 0x42, 0x43];

const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);

fn init_of(a: u8) -> [Transaction; 5] {
    [
        Transaction::write(a, vec![ALL_LED_OFF_H, FULL]),
        Transaction::write(a, vec![MODE1, SLEEP | AI]),
        Transaction::write(a, vec![PRE_SCALE, 3]),
        Transaction::write(a, vec![MODE2, OUTDRV]),
        Transaction::write(a, vec![MODE1, AI]),
    ]
}

fn initialised(then: &[Transaction]) -> Pca9685Set<Mock, 4> {
    let mut expect: Vec<_> = ADDRESSES.iter().flat_map(|&a| init_of(a)).collect();
    expect.extend_from_slice(then);
    let mut set = Pca9685Set::new(Mock::new(&expect), ADDRESSES);
    set.init(1526, &mut NoopDelay).unwrap();
    set
}

#[test]
fn init_turns_every_board_off_first_then_each_key_change_is_one_write_to_its_board() {
    let mut set = initialised(&[
        // Board 2 (0x42), channel 3 (0x12), duty 2048: ON 768 (0x300), OFF 2816 (0xB00).
        Transaction::write(0x42, vec![0x12, 0x00, 0x03, 0x00, 0x0B]),
        // Board 0, channels 0 and 1: one run.
        Transaction::write(
            0x40,
            vec![0x06, 0x00, FULL, 0x00, 0x00, 0x00, 0x01, 0x01, 0x01],
        ),
    ]);
    assert_eq!(set.duty(3, 15), Some(0));
    assert!(set.set_duty(2, 3, 2048).unwrap());
    assert!(!set.set_duty(2, 3, 2048).unwrap());
    let mut duties = [0; 16];
    duties[0] = 4095;
    duties[1] = 1;
    assert!(set.set_duties(0, &duties).unwrap());
    assert_eq!(set.duty(0, 1), Some(1));
    assert_eq!(set.set_duty(4, 0, 1), Err(Error::UnknownBoard(4)));
    assert_eq!(set.duty(4, 0), None);
    set.destroy().done();
}

#[test]
fn a_bad_frequency_writes_nothing_and_init_stops_at_a_board_that_fails() {
    let mut set = Pca9685Set::new(Mock::new(&[]), ADDRESSES);
    assert_eq!(
        set.init(10, &mut NoopDelay),
        Err(Error::Frequency { hz: 10 })
    );
    set.destroy().done();
    let mut expect: Vec<_> = init_of(0x40).into();
    expect.push(Transaction::write(0x41, vec![ALL_LED_OFF_H, FULL]).with_error(NACK));
    let mut set = Pca9685Set::new(Mock::new(&expect), ADDRESSES);
    assert_eq!(set.init(1526, &mut NoopDelay), Err(Error::I2c(NACK)));
    assert_eq!((set.duty(0, 0), set.duty(1, 0)), (Some(0), None));
    set.destroy().done();
}

#[test]
fn all_off_tries_every_board_and_returns_the_first_error() {
    let mut set = initialised(&[
        Transaction::write(0x40, vec![ALL_LED_OFF_H, FULL]),
        Transaction::write(0x41, vec![ALL_LED_OFF_H, FULL]).with_error(NACK),
        Transaction::write(0x42, vec![ALL_LED_OFF_H, FULL]),
        Transaction::write(0x43, vec![ALL_LED_OFF_H, FULL]),
    ]);
    assert_eq!(set.all_off(), Err(Error::I2c(NACK)));
    assert_eq!((set.duty(1, 0), set.duty(2, 0)), (None, Some(0)));
    set.destroy().done();
}

#[test]
fn with_boards_takes_up_to_n() {
    let set: Pca9685Set<Mock, 4> = Pca9685Set::with_boards(Mock::new(&[]), &[0x40, 0x41]).unwrap();
    assert_eq!((set.len(), set.addresses()), (2, &[0x40, 0x41][..]));
    set.destroy().done();
    let mut bus = Mock::new(&[]);
    assert!(Pca9685Set::<&mut Mock, 1>::with_boards(&mut bus, &[0x40, 0x41]).is_none());
    bus.done();
}

#[test]
fn as_finger_boards_a_bit_is_a_channel_fully_on_or_off_in_one_write() {
    use orch_core::{BoardId, FingerBoards};
    let b1 = BoardId {
        index: 1,
        address: 0x41,
    };
    let mut set = initialised(&[
        // Bits 2 and 4: channels 2..=4 in one run, 2 and 4 full ON, 3 (unchanged) full OFF.
        Transaction::write(
            0x41,
            vec![
                0x0E, 0x00, FULL, 0x00, 0x00, 0x00, 0x00, 0x00, FULL, 0x00, FULL, 0x00, 0x00,
            ],
        ),
        Transaction::write(0x41, vec![0x0E, 0x00, 0x00, 0x00, FULL]), // bit 2 released
    ]);
    set.write_board(b1, 0b1_0100).unwrap();
    set.write_board(b1, 0b1_0100).unwrap(); // unchanged: nothing
    set.write_board(b1, 0b1_0000).unwrap();
    assert_eq!(
        set.write_board(
            BoardId {
                index: 1,
                address: 0x40
            },
            1
        ),
        Err(Error::AddressMismatch {
            index: 1,
            expected: 0x41,
            requested: 0x40
        })
    );
    set.destroy().done();
}

/// What orch-core's interpreter plays on a PWM key reaches the chip as it should: middle C at
/// velocity 127 strikes fully on (channel 8 of the second board), drops to the 35 % hold when
/// the 40 ms strike ends, and goes fully off at its release; one 5-byte write each.
#[test]
fn the_interpreters_strike_and_hold_reach_the_channel_as_three_writes() {
    use orch_core::{Config, Dynamics, Instant, Interpreter};
    const LED8_ON_L: u8 = 0x06 + 4 * 8;
    // Channel 8 goes high at count 8 × 256 = 0x800; 35 % = 1433 counts later is 0xD99.
    let mut set = initialised(&[
        Transaction::write(0x41, vec![LED8_ON_L, 0x00, FULL, 0x00, 0x00]),
        Transaction::write(0x41, vec![LED8_ON_L, 0x00, 0x08, 0x99, 0x0D]),
        Transaction::write(0x41, vec![LED8_ON_L, 0x00, 0x00, 0x00, FULL]),
    ]);
    let mut robot: Interpreter = Interpreter::new(Config {
        dynamics: Dynamics::PWM,
        layout: orch_core::Layout {
            boards: core::array::from_fn(|i| orch_core::BoardSpan {
                address: ADDRESSES[i],
                ..Config::THESIS.layout.boards[i]
            }),
        },
        ..Config::THESIS
    })
    .unwrap();
    let ms = Instant::from_millis;
    robot.feed_slice(&[0x90, 60, 127], ms(0));
    assert_eq!(robot.flush_duties(&mut set), Ok(1));
    robot.tick(robot.next_deadline().unwrap());
    assert_eq!(robot.flush_duties(&mut set), Ok(1));
    robot.feed_slice(&[0x80, 60, 0], ms(500));
    assert_eq!(robot.flush_duties(&mut set), Ok(1));
    set.destroy().done();
}
