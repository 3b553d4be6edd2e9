//! A robot that mixes board kinds on one bus: a PCA9555 at 0x21 and a PCA9685 at 0x40, each
//! initialised and written with its own datasheet bytes (re-typed here), each cached apart.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::{Error, MixedBoardSet};
use orch_core::{BoardId, BoardKind, Duty, FingerBoards};

// PCA9555.
const OUTPUT_PORT_0: u8 = 0x02;
const CONFIGURATION_0: u8 = 0x06;
// PCA9685.
const MODE1: u8 = 0x00;
const MODE2: u8 = 0x01;
const LED0_ON_L: u8 = 0x06;
const ALL_LED_OFF_H: u8 = 0xFD;
const PRE_SCALE: u8 = 0xFE;
const AI: u8 = 0x20;
const SLEEP: u8 = 0x10;
const OUTDRV: u8 = 0x04;
const FULL: u8 = 0x10;

const IO: BoardId = BoardId {
    index: 0,
    address: 0x21,
};
const PWM: BoardId = BoardId {
    index: 1,
    address: 0x40,
};

fn init() -> Vec<Transaction> {
    vec![
        Transaction::write(0x21, vec![OUTPUT_PORT_0, 0, 0]),
        Transaction::write(0x21, vec![CONFIGURATION_0, 0, 0]),
        Transaction::write(0x40, vec![ALL_LED_OFF_H, FULL]),
        Transaction::write(0x40, vec![MODE1, SLEEP | AI]),
        // 1 kHz: round(25 MHz / (4096 × 1000)) − 1 = 5.
        Transaction::write(0x40, vec![PRE_SCALE, 5]),
        Transaction::write(0x40, vec![MODE2, OUTDRV]),
        Transaction::write(0x40, vec![MODE1, AI]),
    ]
}

fn set(then: &[Transaction]) -> MixedBoardSet<Mock, 4> {
    let mut expect = init();
    expect.extend_from_slice(then);
    let mut set = MixedBoardSet::with_boards(
        Mock::new(&expect),
        &[(0x21, BoardKind::OnOff), (0x40, BoardKind::Pwm)],
    )
    .unwrap();
    set.init(1_000, &mut NoopDelay).unwrap();
    set
}

fn duties(pairs: &[(usize, u16)]) -> [Duty; 16] {
    let mut d = [Duty::OFF; 16];
    for &(n, v) in pairs {
        d[n] = Duty::new(v).unwrap();
    }
    d
}

#[test]
fn each_board_kind_gets_its_own_bytes_and_an_unchanged_board_costs_nothing() {
    let mut set = set(&[
        // Duties to the on/off board: outputs 1 and 3 on.
        Transaction::write(0x21, vec![OUTPUT_PORT_0, 0b1010, 0]),
        // Duties to the PWM board: channel 2 at 1433 (high at 512 = 0x200, low at 0x799).
        Transaction::write(0x40, vec![LED0_ON_L + 8, 0x00, 0x02, 0x99, 0x07]),
        // On/off outputs to the PWM board: channels 2 and 3 fully on, in one run.
        Transaction::write(
            0x40,
            vec![
                LED0_ON_L + 8,
                0x00,
                FULL,
                0x00,
                0x00,
                0x00,
                FULL,
                0x00,
                0x00,
            ],
        ),
    ]);
    set.write_duties(IO, &duties(&[(1, 4095), (3, 1)])).unwrap();
    set.write_duties(IO, &duties(&[(1, 2000), (3, 4095)]))
        .unwrap(); // same outputs: nothing
    set.write_duties(PWM, &duties(&[(2, 1433)])).unwrap();
    set.write_duties(PWM, &duties(&[(2, 1433)])).unwrap(); // unchanged: nothing
    assert_eq!(set.duty(1, 2), Some(1433));
    set.write_board(PWM, 0b1100).unwrap();
    assert_eq!(set.duty(0, 2), None, "board 0 is not a PWM board");
    assert_eq!(set.kinds(), &[BoardKind::OnOff, BoardKind::Pwm]);
    set.destroy().done();
}

#[test]
fn a_failed_write_is_sent_again_and_release_all_reaches_every_board() {
    let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    let mut set = set(&[
        Transaction::write(0x40, vec![LED0_ON_L, 0x00, FULL, 0x00, 0x00]).with_error(nack),
        Transaction::write(0x40, vec![LED0_ON_L, 0x00, FULL, 0x00, 0x00]),
        Transaction::write(0x21, vec![OUTPUT_PORT_0, 0, 0]).with_error(nack),
        Transaction::write(0x40, vec![ALL_LED_OFF_H, FULL]),
    ]);
    let full = duties(&[(0, 4095)]);
    assert_eq!(set.write_duties(PWM, &full), Err(Error::I2c(nack)));
    set.write_duties(PWM, &full).unwrap();
    // The on/off board holds 0 since init; release_all writes it anyway (and the PWM board
    // after it, though the first failed).
    set.invalidate();
    assert_eq!(set.release_all(), Err(Error::I2c(nack)));
    assert_eq!(
        set.write_board(
            BoardId {
                index: 1,
                address: 0x41
            },
            1
        ),
        Err(Error::AddressMismatch {
            index: 1,
            expected: 0x40,
            requested: 0x41
        })
    );
    assert_eq!(
        set.write_board(
            BoardId {
                index: 2,
                address: 0x42
            },
            1
        ),
        Err(Error::UnknownBoard(2))
    );
    set.destroy().done();
}
