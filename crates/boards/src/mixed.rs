//! A robot whose finger boards are of both kinds on one bus: PCA9555 (on/off) and PCA9685
//! (PWM), each written with its own driver's bytes and cache.

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;
use orch_core::{full_or_off, on_off, BoardId, BoardKind, Duty, FingerBoards};

use crate::pca9685::frames::State;
use crate::pca9685::{device, Prescale, CHANNELS};
use crate::{frames, Error};

/// One bus and up to `N` finger boards of either kind ([`BoardKind`]), in layout order.
///
/// - A PCA9555 board is written as [`FingerBoardSet`](crate::FingerBoardSet) writes it: one
///   `[0x02, lo, hi]` a change; [`write_duties`](FingerBoards::write_duties) sends it the
///   outputs whose duty is above 0.
/// - A PCA9685 board is written as [`Pca9685Set`](crate::Pca9685Set) writes it: one write of
///   the run of channels that changed; [`write_board`](FingerBoards::write_board) sends a set
///   bit as fully on.
///
/// Each board keeps its own cache of what it holds (a failed write forgets it), so an
/// unchanged board costs no bus time.
#[derive(Debug)]
pub struct MixedBoardSet<I2C, const N: usize> {
    i2c: I2C,
    addresses: [u8; N],
    kinds: [BoardKind; N],
    /// PCA9555 boards: the outputs last written.
    last: [Option<u16>; N],
    /// PCA9685 boards: each channel's duty last written.
    pwm: [State; N],
    len: usize,
}

impl<I2C: I2c, const N: usize> MixedBoardSet<I2C, N> {
    /// A set of the boards in `boards` (address and kind, in layout order) on `i2c`, or
    /// `None` if there are more than `N`. Nothing is written: call [`init`](Self::init).
    pub fn with_boards(i2c: I2C, boards: &[(u8, BoardKind)]) -> Option<Self> {
        if boards.len() > N {
            return None;
        }
        let mut addresses = [0u8; N];
        let mut kinds = [BoardKind::OnOff; N];
        for (i, &(address, kind)) in boards.iter().enumerate() {
            addresses[i] = address;
            kinds[i] = kind;
        }
        Some(Self {
            i2c,
            addresses,
            kinds,
            last: [None; N],
            pwm: [State::UNKNOWN; N],
            len: boards.len(),
        })
    }

    /// Initialises every board, in order: a PCA9555 as
    /// [`FingerBoardSet::init`](crate::FingerBoardSet::init) does (outputs 0, then every pin
    /// an output), a PCA9685 as [`Pca9685::init`](crate::Pca9685::init) does at `pwm_hz`
    /// (every channel off first). Stops at the first board that fails.
    pub fn init(&mut self, pwm_hz: u32, delay: &mut impl DelayNs) -> Result<(), Error<I2C::Error>> {
        for i in 0..self.len {
            self.init_board(i as u8, pwm_hz, delay)?;
        }
        Ok(())
    }

    /// Initialises board `index` as [`init`](Self::init) does (a board that came back after
    /// a power cycle, say).
    pub fn init_board(
        &mut self,
        index: u8,
        pwm_hz: u32,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<I2C::Error>> {
        let i = usize::from(index);
        if i >= self.len {
            return Err(Error::UnknownBoard(index));
        }
        let address = self.addresses[i];
        match self.kinds[i] {
            BoardKind::OnOff => {
                self.last[i] = None;
                self.i2c.write(address, &frames::outputs(0))?;
                self.i2c.write(address, &frames::ALL_OUTPUTS)?;
                self.last[i] = Some(0);
                Ok(())
            }
            BoardKind::Pwm => {
                let prescale = Prescale::from_hz(pwm_hz).ok_or(Error::Frequency { hz: pwm_hz })?;
                device::init(&mut self.i2c, address, &mut self.pwm[i], prescale, delay)
            }
        }
    }

    /// Every output of every board off: tries every board, returns the first error.
    pub fn release_all(&mut self) -> Result<(), Error<I2C::Error>> {
        let mut first = Ok(());
        for i in 0..self.len {
            let result = match self.kinds[i] {
                BoardKind::OnOff => self.write_on_off(i, 0),
                BoardKind::Pwm => {
                    device::all_off(&mut self.i2c, self.addresses[i], &mut self.pwm[i])
                }
            };
            if first.is_ok() {
                first = result;
            }
        }
        first
    }

    /// Forgets what every board holds, so the next write to each goes out.
    pub fn invalidate(&mut self) {
        self.last = [None; N];
        for state in &mut self.pwm {
            state.duties = [None; CHANNELS];
        }
    }

    /// The boards' addresses, in layout order.
    pub fn addresses(&self) -> &[u8] {
        &self.addresses[..self.len]
    }

    /// The boards' kinds, in layout order.
    pub fn kinds(&self) -> &[BoardKind] {
        &self.kinds[..self.len]
    }

    /// The duty channel `channel` of PWM board `index` last got, if known.
    pub fn duty(&self, index: u8, channel: u8) -> Option<u16> {
        let i = usize::from(index);
        if i >= self.len || self.kinds[i] != BoardKind::Pwm {
            return None;
        }
        self.pwm[i]
            .duties
            .get(usize::from(channel))
            .copied()
            .flatten()
    }

    /// The bus.
    pub fn bus(&self) -> &I2C {
        &self.i2c
    }

    /// The bus, to drive directly (what the boards hold is then unknown to the set: call
    /// [`invalidate`](Self::invalidate) after writing to them).
    pub fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// Gives the bus back.
    pub fn destroy(self) -> I2C {
        self.i2c
    }

    /// PWM board `index`'s bus, address and cache, for a write of the single-board driver's
    /// ([`Pca9685Set`](crate::Pca9685Set)'s channel writes); [`Error::UnknownBoard`] if the
    /// set has no such PWM board.
    pub(crate) fn pwm_board(
        &mut self,
        index: u8,
    ) -> Result<(&mut I2C, u8, &mut State), Error<I2C::Error>> {
        let i = usize::from(index);
        if i >= self.len || self.kinds[i] != BoardKind::Pwm {
            return Err(Error::UnknownBoard(index));
        }
        Ok((&mut self.i2c, self.addresses[i], &mut self.pwm[i]))
    }

    /// The board `board` names, checked.
    fn slot(&self, board: BoardId) -> Result<usize, Error<I2C::Error>> {
        let i = usize::from(board.index);
        if i >= self.len {
            return Err(Error::UnknownBoard(board.index));
        }
        if self.addresses[i] != board.address {
            return Err(Error::AddressMismatch {
                index: board.index,
                expected: self.addresses[i],
                requested: board.address,
            });
        }
        Ok(i)
    }

    fn write_on_off(&mut self, i: usize, outputs: u16) -> Result<(), Error<I2C::Error>> {
        if self.last[i] == Some(outputs) {
            return Ok(());
        }
        self.last[i] = None;
        self.i2c
            .write(self.addresses[i], &frames::outputs(outputs))?;
        self.last[i] = Some(outputs);
        Ok(())
    }

    fn write_pwm(&mut self, i: usize, duties: &[u16; CHANNELS]) -> Result<(), Error<I2C::Error>> {
        device::set_duties(&mut self.i2c, self.addresses[i], &mut self.pwm[i], duties).map(|_| ())
    }
}

impl<I2C: I2c, const N: usize> FingerBoards for MixedBoardSet<I2C, N> {
    type Error = Error<I2C::Error>;

    /// On/off outputs: a PCA9555's one write, or a PCA9685's channels fully on or off.
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        let i = self.slot(board)?;
        match self.kinds[i] {
            BoardKind::OnOff => self.write_on_off(i, outputs),
            BoardKind::Pwm => self.write_pwm(i, &full_or_off(outputs).map(|d| d.get())),
        }
    }

    /// Duties: a PCA9685's write of the channels that changed, or a PCA9555's outputs with a
    /// duty above 0.
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Self::Error> {
        let i = self.slot(board)?;
        match self.kinds[i] {
            BoardKind::OnOff => self.write_on_off(i, on_off(duties)),
            BoardKind::Pwm => self.write_pwm(i, &duties.map(|d| d.get())),
        }
    }
}
