//! [`Pca9685Set`]: N PCA9685 boards on one blocking bus.

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;

use super::device;
use super::frames::State;
use super::{Prescale, CHANNELS};
use crate::Error;

/// `N` PCA9685 boards on one blocking bus, each with its own cache: what
/// [`Pca9685`](crate::Pca9685) does for one board, for a robot's boards. Board `i` is
/// `addresses[i]`; every write is the single-board driver's, byte for byte.
#[derive(Debug)]
pub struct Pca9685Set<I2C, const N: usize> {
    i2c: I2C,
    addresses: [u8; N],
    states: [State; N],
    /// Boards in use: the first `len` of the `N` slots.
    len: usize,
}

impl<I2C: I2c, const N: usize> Pca9685Set<I2C, N> {
    /// A set of boards at these 7-bit addresses. Does no bus traffic: call
    /// [`init`](Self::init) next.
    pub fn new(i2c: I2C, addresses: [u8; N]) -> Self {
        Self {
            i2c,
            addresses,
            states: [State::UNKNOWN; N],
            len: N,
        }
    }

    /// A set of up to `N` boards at these addresses, for a robot whose number of boards is
    /// known only at run time. `None` if there are more than `N`. Does no bus traffic.
    pub fn with_boards(i2c: I2C, addresses: &[u8]) -> Option<Self> {
        if addresses.len() > N {
            return None;
        }
        let mut all = [0u8; N];
        all[..addresses.len()].copy_from_slice(addresses);
        Some(Self {
            i2c,
            addresses: all,
            states: [State::UNKNOWN; N],
            len: addresses.len(),
        })
    }

    /// How many boards the set drives.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the set drives no board.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Initialises every board in index order at `hz`, each as
    /// [`Pca9685::init`](crate::Pca9685::init) does (every channel off first). A frequency the
    /// chip cannot make is refused before anything is written; a bus error stops at that board
    /// (the boards after it keep their power-up state: asleep, every channel off).
    pub fn init(&mut self, hz: u32, delay: &mut impl DelayNs) -> Result<(), Error<I2C::Error>> {
        let prescale = Prescale::from_hz(hz).ok_or(Error::Frequency { hz })?;
        for i in 0..self.len {
            device::init(
                &mut self.i2c,
                self.addresses[i],
                &mut self.states[i],
                prescale,
                delay,
            )?;
        }
        Ok(())
    }

    /// One channel of board `board`, as [`Pca9685::set_duty`](crate::Pca9685::set_duty): one
    /// 5-byte write unless unchanged. Returns whether it wrote.
    pub fn set_duty(
        &mut self,
        board: u8,
        channel: u8,
        duty: u16,
    ) -> Result<bool, Error<I2C::Error>> {
        let i = self.slot(board)?;
        device::set_duty(
            &mut self.i2c,
            self.addresses[i],
            &mut self.states[i],
            channel,
            duty,
        )
    }

    /// All 16 duties of board `board`, as [`Pca9685::set_duties`](crate::Pca9685::set_duties):
    /// one write of the changed run. Returns whether it wrote.
    pub fn set_duties(
        &mut self,
        board: u8,
        duties: &[u16; CHANNELS],
    ) -> Result<bool, Error<I2C::Error>> {
        let i = self.slot(board)?;
        device::set_duties(
            &mut self.i2c,
            self.addresses[i],
            &mut self.states[i],
            duties,
        )
    }

    /// Every channel of every board fully off (`[ALL_LED_OFF_H, 0x10]` to each), whatever the
    /// caches say, trying every board even when one fails. Returns the first error. For
    /// stopping.
    pub fn all_off(&mut self) -> Result<(), Error<I2C::Error>> {
        let mut first = Ok(());
        for i in 0..self.len {
            let result = device::all_off(&mut self.i2c, self.addresses[i], &mut self.states[i]);
            if first.is_ok() {
                first = result;
            }
        }
        first
    }

    /// Channel `channel` of board `board` as last written successfully, or `None` when unknown
    /// or when there is no such board or channel.
    pub fn duty(&self, board: u8, channel: u8) -> Option<u16> {
        let state = self.states[..self.len].get(usize::from(board))?;
        state.duties.get(usize::from(channel)).copied().flatten()
    }

    /// Forgets every board's duties, so the next write to each channel goes out.
    pub fn invalidate(&mut self) {
        for state in &mut self.states {
            state.duties = [None; CHANNELS];
        }
    }

    /// The boards' addresses, by index.
    pub fn addresses(&self) -> &[u8] {
        &self.addresses[..self.len]
    }

    /// The bus, to look at.
    pub fn bus(&self) -> &I2C {
        &self.i2c
    }

    /// The bus, to use between writes (set a simulated bus's time, say). A write that changes
    /// a board behind the set's back must be followed by [`invalidate`](Self::invalidate).
    pub fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// Gives the bus back. Does no bus traffic.
    pub fn destroy(self) -> I2C {
        self.i2c
    }

    fn slot(&self, board: u8) -> Result<usize, Error<I2C::Error>> {
        let i = usize::from(board);
        if i < self.len {
            Ok(i)
        } else {
            Err(Error::UnknownBoard(board))
        }
    }
}

/// On/off playing on PWM boards, for today's interpreter (velocity ignored, as on a PCA9555):
/// bit `n` of `outputs` sets channel `n` fully on (duty [`FULL_ON`](super::FULL_ON)) or fully
/// off. A separate adapter, not the PWM design: strike and hold profiles belong to the core.
impl<I2C: I2c, const N: usize> orch_core::FingerBoards for Pca9685Set<I2C, N> {
    type Error = Error<I2C::Error>;

    /// One write of the run of channels that changed ([`set_duties`](Pca9685Set::set_duties)),
    /// or none. `board.index` must be a board of the set ([`Error::UnknownBoard`]) and
    /// `board.address` its address ([`Error::AddressMismatch`]).
    fn write_board(&mut self, board: orch_core::BoardId, outputs: u16) -> Result<(), Self::Error> {
        let duties = orch_core::full_or_off(outputs).map(|d| d.get());
        self.write_duty_values(board, &duties)
    }

    /// The duties the interpreter plays ([`Interpreter::flush_duties`](orch_core::Interpreter::flush_duties):
    /// strike, then hold), in one write of the run of channels that changed, or none. The
    /// core's [`Duty`](orch_core::Duty) is this chip's 0..=4095 (4095: fully on).
    fn write_duties(
        &mut self,
        board: orch_core::BoardId,
        duties: &[orch_core::Duty; 16],
    ) -> Result<(), Self::Error> {
        self.write_duty_values(board, &duties.map(|d| d.get()))
    }
}

impl<I2C: I2c, const N: usize> Pca9685Set<I2C, N> {
    /// [`set_duties`](Self::set_duties) for the board `board` names, checking its address.
    fn write_duty_values(
        &mut self,
        board: orch_core::BoardId,
        duties: &[u16; 16],
    ) -> Result<(), Error<I2C::Error>> {
        let i = self.slot(board.index)?;
        if self.addresses[i] != board.address {
            return Err(Error::AddressMismatch {
                index: board.index,
                expected: self.addresses[i],
                requested: board.address,
            });
        }
        self.set_duties(board.index, duties).map(|_| ())
    }
}
