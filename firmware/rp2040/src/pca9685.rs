//! The `pca9685` build's finger boards: five PCA9685 PWM boards at 0x40..=0x44 on the same
//! I2C pins (the keyboard on the first four, the drum kit on the fifth: [`crate::robot`]), and
//! their active-low output-enable pin (OE) on GP6.
//!
//! - Each board is initialised by orch-boards' `Pca9685Async::init_prescale`: every channel
//!   fully off (`[ALL_LED_OFF_H, 0x10]`) FIRST, then asleep, the prescale (1526 Hz), `MODE2`
//!   totem pole, awake with auto-increment, 500 µs for the oscillator. It answers within the
//!   same 2 ms limit as every bus operation (five writes of 29 bit-times, 0.36 ms at 400 kHz,
//!   and the 500 µs wait).
//! - orch-core plays each press as a strike at its velocity's duty, then a hold
//!   ([`crate::robot::PCA9685`]); `flush_duties` hands over each changed board's 16 duties and
//!   the driver writes the run of channels that changed in one auto-increment write (one key:
//!   5 bytes, 56 bit-times, 140 µs). The loop wakes at `next_deadline`, which includes the end
//!   of every strike, and writes the hold then; and the end of every drum hit's pulse, and
//!   writes the beater's channel off then (whatever the Note-Off does).
//! - **OE, the hardware stop** (GP6, to every board's OE, with a pull-up to 3.3 V on the board
//!   side): driven high (every output off, whatever the registers say: `MODE2`'s OUTNE = 00)
//!   from reset until the power-up round has initialised the boards all off, then low. It goes
//!   high again while no board is in service (a hung bus sets them all aside: the keys that were
//!   down cannot be released by a write, so OE releases them), and on a panic, before the
//!   all-off writes. The watchdog's reset returns the pin to an input: the pull-up raises OE at
//!   that instant, before the firmware runs again.

use core::convert::Infallible;

use embassy_rp::gpio::{Level, Output};
use embassy_rp::pac;
use embassy_time::Delay;
use orch_boards::asynch::Pca9685Async;
use orch_boards::pca9685::registers::{ALL_LED_OFF_H, FULL_ON_OFF};
use orch_boards::pca9685::Prescale;
use orch_core::{BoardId, Duty, FingerBoards};
use static_cell::StaticCell;

use crate::bus::{self, Fault};
pub use crate::robot::{Robot, BOARDS};
use crate::robot::{PCA9685, PCA9685_ADDRESSES};
use crate::{BusDevice, ALL};

/// The boards' 7-bit addresses.
pub const ADDRESSES: [u8; BOARDS] = PCA9685_ADDRESSES;
/// The OE pin: GP6 (the Pico's pin 9, beside SDA GP4 on pin 6 and SCL GP5 on pin 7).
pub const OE_PIN: usize = 6;
/// The PWM frequency: the chip's highest, orch-boards' default (1526 Hz, `PRE_SCALE` 3).
const PRESCALE: Prescale = Prescale::DEFAULT;

/// What one board is sent: its 16 channels' duties (0..=4095, 4095 fully on).
pub type Frame = [u16; 16];

/// The interpreter on [`PCA9685`]: checked at start-up (a setting it refuses is a panic, and
/// the panic handler keeps every output off), in a static.
pub fn robot() -> &'static mut Robot {
    static ROBOT: StaticCell<Robot> = StaticCell::new();
    ROBOT.init_with(|| Robot::new(PCA9685).expect("the PCA9685 robot's settings"))
}

/// The five boards and their OE pin.
pub struct Boards {
    boards: [Pca9685Async<BusDevice>; BOARDS],
    /// High: every output off.
    oe: Output<'static>,
}

impl Boards {
    /// The boards on `device()`, and `oe` (driven high from the start). Does no bus traffic.
    pub fn new(mut device: impl FnMut() -> BusDevice, oe: Output<'static>) -> Self {
        Self {
            boards: ADDRESSES.map(|a| Pca9685Async::new(device(), a)),
            oe,
        }
    }

    /// Board `i` initialised: every channel off first.
    pub async fn init(&mut self, i: usize) -> Result<(), Fault> {
        bus::within(self.boards[i].init_prescale(PRESCALE, &mut Delay)).await
    }

    /// Board `i` sent `frame`: one write of the run of channels whose duty changed (none if
    /// none did).
    pub async fn set(&mut self, i: usize, frame: &Frame) -> Result<(), Fault> {
        bus::within(self.boards[i].set_duties(frame))
            .await
            .map(drop)
    }

    /// OE low (outputs enabled) while some board is in service, high (every output off) while
    /// none is. `failed`: bit `i` set while board `i` is set aside.
    pub fn in_service(&mut self, failed: u8) {
        self.oe.set_level(if failed == ALL {
            Level::High
        } else {
            Level::Low
        });
    }
}

/// The boards whose duties changed, as orch-core's `flush_duties` hands them over (it takes
/// them as written; the async writes follow).
pub fn changed(robot: &mut Robot) -> [Option<Frame>; BOARDS] {
    let mut changed = Changed::default();
    let _ = robot.flush_duties(&mut changed);
    changed.0
}

/// Board `i`'s duties now, for a board initialised again.
pub fn frame(robot: &Robot, i: usize) -> Frame {
    robot.duties()[i].map(Duty::get)
}

/// Whether `frame` has every channel off (an initialised board already shows it).
pub fn is_off(frame: &Frame) -> bool {
    frame.iter().all(|&d| d == 0)
}

/// For the panic handler: OE high at once (every output off), then every channel of every
/// board fully off (`[ALL_LED_OFF_H, 0x10]`), so the keys stay up after the reset lets go of OE.
pub fn release_all_now() {
    let bit = 1u32 << OE_PIN;
    pac::SIO.gpio_out(0).value_set().write_value(bit);
    pac::SIO.gpio_oe(0).value_set().write_value(bit);
    bus::write_all_now(&ADDRESSES, &[ALL_LED_OFF_H, FULL_ON_OFF]);
}

#[derive(Default)]
struct Changed([Option<Frame>; BOARDS]);

impl FingerBoards for Changed {
    type Error = Infallible;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Infallible> {
        // flush_duties writes through write_duties; on/off outputs are full duties.
        let frame = core::array::from_fn(|n| {
            if outputs & (1 << n) != 0 {
                Duty::FULL.get()
            } else {
                0
            }
        });
        if let Some(slot) = self.0.get_mut(board.index as usize) {
            *slot = Some(frame);
        }
        Ok(())
    }
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Infallible> {
        if let Some(slot) = self.0.get_mut(board.index as usize) {
            *slot = Some(duties.map(Duty::get));
        }
        Ok(())
    }
}
