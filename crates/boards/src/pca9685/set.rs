//! [`Pca9685Set`]: N PCA9685 boards on one blocking bus.

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;
use orch_core::{BoardId, BoardKind, Duty, FingerBoards};

use super::device;
use super::{Prescale, CHANNELS};
use crate::{Error, MixedBoardSet};

/// `N` PCA9685 boards on one blocking bus, each with its own cache: what
/// [`Pca9685`](crate::Pca9685) does for one board, for a robot's boards. Board `i` is
/// `addresses[i]`; every write is the single-board driver's, byte for byte. A
/// [`MixedBoardSet`] whose boards are all PWM, with a channel at a time besides.
#[derive(Debug)]
pub struct Pca9685Set<I2C, const N: usize>(MixedBoardSet<I2C, N>);

impl<I2C: I2c, const N: usize> Pca9685Set<I2C, N> {
    /// A set of boards at these 7-bit addresses. Does no bus traffic: call
    /// [`init`](Self::init) next.
    pub fn new(i2c: I2C, addresses: [u8; N]) -> Self {
        Self::with_boards(i2c, &addresses).expect("N boards fit a set of N")
    }

    /// A set of up to `N` boards at these addresses, for a robot whose number of boards is
    /// known only at run time. `None` if there are more than `N`. Does no bus traffic.
    pub fn with_boards(i2c: I2C, addresses: &[u8]) -> Option<Self> {
        if addresses.len() > N {
            return None;
        }
        let mut boards = [(0u8, BoardKind::Pwm); N];
        for (b, &a) in boards.iter_mut().zip(addresses) {
            b.0 = a;
        }
        MixedBoardSet::with_boards(i2c, &boards[..addresses.len()]).map(Self)
    }

    /// How many boards the set drives.
    pub fn len(&self) -> usize {
        self.0.addresses().len()
    }

    /// Whether the set drives no board.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Initialises every board in index order at `hz`, each as
    /// [`Pca9685::init`](crate::Pca9685::init) does (every channel off first). A frequency the
    /// chip cannot make is refused before anything is written; a bus error stops at that board
    /// (the boards after it keep their power-up state: asleep, every channel off).
    pub fn init(&mut self, hz: u32, delay: &mut impl DelayNs) -> Result<(), Error<I2C::Error>> {
        Prescale::from_hz(hz).ok_or(Error::Frequency { hz })?;
        self.0.init(hz, delay)
    }

    /// One channel of board `board`, as [`Pca9685::set_duty`](crate::Pca9685::set_duty): one
    /// 5-byte write unless unchanged. Returns whether it wrote.
    pub fn set_duty(
        &mut self,
        board: u8,
        channel: u8,
        duty: u16,
    ) -> Result<bool, Error<I2C::Error>> {
        let (i2c, address, state) = self.0.pwm_board(board)?;
        device::set_duty(i2c, address, state, channel, duty)
    }

    /// All 16 duties of board `board`, as [`Pca9685::set_duties`](crate::Pca9685::set_duties):
    /// one write of the changed run. Returns whether it wrote.
    pub fn set_duties(
        &mut self,
        board: u8,
        duties: &[u16; CHANNELS],
    ) -> Result<bool, Error<I2C::Error>> {
        let (i2c, address, state) = self.0.pwm_board(board)?;
        device::set_duties(i2c, address, state, duties)
    }

    /// Every channel of every board fully off (`[ALL_LED_OFF_H, 0x10]` to each), whatever the
    /// caches say, trying every board even when one fails. Returns the first error. For
    /// stopping.
    pub fn all_off(&mut self) -> Result<(), Error<I2C::Error>> {
        self.0.release_all()
    }

    /// Channel `channel` of board `board` as last written successfully, or `None` when unknown
    /// or when there is no such board or channel.
    pub fn duty(&self, board: u8, channel: u8) -> Option<u16> {
        self.0.duty(board, channel)
    }

    /// Forgets every board's duties, so the next write to each channel goes out.
    pub fn invalidate(&mut self) {
        self.0.invalidate();
    }

    /// The boards' addresses, by index.
    pub fn addresses(&self) -> &[u8] {
        self.0.addresses()
    }

    /// The bus, to look at.
    pub fn bus(&self) -> &I2C {
        self.0.bus()
    }

    /// The bus, to use between writes (set a simulated bus's time, say). A write that changes
    /// a board behind the set's back must be followed by [`invalidate`](Self::invalidate).
    pub fn bus_mut(&mut self) -> &mut I2C {
        self.0.bus_mut()
    }

    /// Gives the bus back. Does no bus traffic.
    pub fn destroy(self) -> I2C {
        self.0.destroy()
    }
}

/// On/off playing on PWM boards, for today's interpreter (velocity ignored, as on a PCA9555):
/// bit `n` of `outputs` sets channel `n` fully on (duty [`FULL_ON`](super::FULL_ON)) or fully
/// off. A separate adapter, not the PWM design: strike and hold profiles belong to the core.
impl<I2C: I2c, const N: usize> FingerBoards for Pca9685Set<I2C, N> {
    type Error = Error<I2C::Error>;

    /// One write of the run of channels that changed ([`set_duties`](Pca9685Set::set_duties)),
    /// or none. `board.index` must be a board of the set ([`Error::UnknownBoard`]) and
    /// `board.address` its address ([`Error::AddressMismatch`]).
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        self.0.write_board(board, outputs)
    }

    /// The duties the interpreter plays ([`Interpreter::flush_duties`](orch_core::Interpreter::flush_duties):
    /// strike, then hold), in one write of the run of channels that changed, or none. The
    /// core's [`Duty`] is this chip's 0..=4095 (4095: fully on).
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Self::Error> {
        self.0.write_duties(board, duties)
    }
}
