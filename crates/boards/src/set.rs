//! [`FingerBoardSet`]: N boards on one bus, as an [`orch_core::FingerBoards`].

use embedded_hal::i2c::I2c;
use orch_core::{BoardId, FingerBoards};

use crate::{frames, Error};

/// `N` PCA9555 / TCA9555 finger boards on one blocking bus.
///
/// Implements [`FingerBoards`]: each write is one transaction `[0x02, lo, hi]` to one board,
/// and only when the value differs from the last one written successfully to that board.
/// A failed write leaves that board unknown, so the next write to it goes out whatever its
/// value.
///
/// The cache answers for the driver only: if a board may have reset (brown-out, hot-plug),
/// call [`init_board`](Self::init_board) or [`invalidate`](Self::invalidate) together with
/// `FingerFrame::invalidate` in orch-core.
#[derive(Debug)]
pub struct FingerBoardSet<I2C, const N: usize> {
    i2c: I2C,
    addresses: [u8; N],
    last: [Option<u16>; N],
    /// Boards in use: the first `len` of the `N` slots.
    len: usize,
}

impl<I2C: I2c, const N: usize> FingerBoardSet<I2C, N> {
    /// A set of boards at these 7-bit addresses; board `i` is `addresses[i]`.
    /// Does no bus traffic: call [`init`](Self::init) next.
    pub fn new(i2c: I2C, addresses: [u8; N]) -> Self {
        Self {
            i2c,
            addresses,
            last: [None; N],
            len: N,
        }
    }

    /// A set of up to `N` boards at these 7-bit addresses (board `i` is `addresses[i]`), for a
    /// robot whose number of boards is known only at run time. `None` if there are more than
    /// `N`. Does no bus traffic: call [`init`](Self::init) next.
    pub fn with_boards(i2c: I2C, addresses: &[u8]) -> Option<Self> {
        if addresses.len() > N {
            return None;
        }
        let mut all = [0u8; N];
        all[..addresses.len()].copy_from_slice(addresses);
        Some(Self {
            i2c,
            addresses: all,
            last: [None; N],
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

    /// The bus, to look at.
    pub fn bus(&self) -> &I2C {
        &self.i2c
    }

    /// The bus, to use between board writes (set a simulated bus's time, say). A transaction
    /// that changes a board's outputs behind the driver's back must be followed by
    /// [`invalidate`](Self::invalidate).
    pub fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// Initialises every board in index order, each as [`Pca9555::init`](crate::Pca9555::init)
    /// does: outputs to 0 first, then all pins outputs. Stops at the first failure (that
    /// board and the ones after it keep their pins as inputs); safe to call again.
    pub fn init(&mut self) -> Result<(), Error<I2C::Error>> {
        for index in 0..self.len {
            self.init_index(index)?;
        }
        Ok(())
    }

    /// Initialises one board, as [`init`](Self::init) does for each.
    pub fn init_board(&mut self, index: u8) -> Result<(), Error<I2C::Error>> {
        let i = self.slot(index)?;
        self.init_index(i)
    }

    /// Writes 0 to every board, whatever the cache says, trying every board even when one
    /// fails. Returns the first error. For stopping: every finger up.
    pub fn release_all(&mut self) -> Result<(), Error<I2C::Error>> {
        let mut first = Ok(());
        for i in 0..self.len {
            if let Err(e) = self.write_index(i, 0) {
                if first.is_ok() {
                    first = Err(e);
                }
            }
        }
        first
    }

    /// The last value written successfully to board `index`, or `None` when unknown or when
    /// there is no such board.
    pub fn last_written(&self, index: u8) -> Option<u16> {
        self.last.get(usize::from(index)).copied().flatten()
    }

    /// Forgets every board's last value, so the next write to each goes out.
    pub fn invalidate(&mut self) {
        self.last = [None; N];
    }

    /// The boards' addresses, by index.
    pub fn addresses(&self) -> &[u8] {
        &self.addresses[..self.len]
    }

    /// Gives the bus back. Does no bus traffic.
    pub fn destroy(self) -> I2C {
        self.i2c
    }

    fn slot(&self, index: u8) -> Result<usize, Error<I2C::Error>> {
        let i = usize::from(index);
        if i < self.len {
            Ok(i)
        } else {
            Err(Error::UnknownBoard(index))
        }
    }

    fn init_index(&mut self, i: usize) -> Result<(), Error<I2C::Error>> {
        self.last[i] = None;
        let address = self.addresses[i];
        self.i2c.write(address, &frames::outputs(0))?;
        self.i2c.write(address, &frames::ALL_OUTPUTS)?;
        self.last[i] = Some(0);
        Ok(())
    }

    fn write_index(&mut self, i: usize, outputs: u16) -> Result<(), Error<I2C::Error>> {
        self.last[i] = None;
        self.i2c
            .write(self.addresses[i], &frames::outputs(outputs))?;
        self.last[i] = Some(outputs);
        Ok(())
    }
}

impl<I2C: I2c, const N: usize> FingerBoards for FingerBoardSet<I2C, N> {
    type Error = Error<I2C::Error>;

    /// One write `[0x02, lo, hi]` to `board.address`, unless the board already holds
    /// `outputs`. `board.index` must be below `N` ([`Error::UnknownBoard`]) and
    /// `board.address` must be the address the set holds for it ([`Error::AddressMismatch`]).
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        let i = self.slot(board.index)?;
        if self.addresses[i] != board.address {
            return Err(Error::AddressMismatch {
                index: board.index,
                expected: self.addresses[i],
                requested: board.address,
            });
        }
        if self.last[i] == Some(outputs) {
            return Ok(());
        }
        self.write_index(i, outputs)
    }
}
