//! A recording test double for [`FingerBoards`]: keeps every write, allocation-free.

use crate::dynamics::Duty;
use crate::output::{full_or_off, on_off, BoardId, FingerBoards};

/// One recorded board write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Write {
    /// The board written.
    pub board: BoardId,
    /// The 16 outputs written (for a duty write: those with a duty above 0).
    pub outputs: u16,
    /// The 16 duties, for a write of duties ([`FingerBoards::write_duties`]); `None` for an
    /// on/off write.
    pub duties: Option<[Duty; 16]>,
}

/// Records up to `CAP` writes and the latest outputs of up to 16 boards.
///
/// Writes past `CAP` are still applied to [`Recording::outputs`] and counted in
/// [`Recording::overflowed`]. A board can be told to fail, to test error paths.
#[derive(Clone, Debug)]
pub struct Recording<const CAP: usize> {
    writes: [Option<Write>; CAP],
    len: usize,
    overflowed: usize,
    outputs: [u16; 16],
    duties: [[Duty; 16]; 16],
    fail_address: Option<u8>,
}

/// The error a [`Recording`] returns for a board told to fail.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Nack(pub u8);

impl<const CAP: usize> Default for Recording<CAP> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const CAP: usize> Recording<CAP> {
    /// An empty recording; every board starts at 0.
    pub const fn new() -> Self {
        Self {
            writes: [None; CAP],
            len: 0,
            overflowed: 0,
            outputs: [0; 16],
            duties: [[Duty::OFF; 16]; 16],
            fail_address: None,
        }
    }

    /// The writes recorded, oldest first.
    pub fn writes(&self) -> impl Iterator<Item = Write> + '_ {
        self.writes[..self.len].iter().flatten().copied()
    }

    /// How many writes were recorded.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing was written.
    pub fn is_empty(&self) -> bool {
        self.len == 0 && self.overflowed == 0
    }

    /// Writes that did not fit.
    pub fn overflowed(&self) -> usize {
        self.overflowed
    }

    /// The last outputs written to board `index`.
    pub fn outputs(&self, index: u8) -> u16 {
        self.outputs[index as usize & 15]
    }

    /// The last duties of board `index`'s outputs (an on/off write sets [`Duty::FULL`] or
    /// [`Duty::OFF`]).
    pub fn duties(&self, index: u8) -> [Duty; 16] {
        self.duties[index as usize & 15]
    }

    /// Forgets the recorded writes (the boards keep their outputs).
    pub fn clear(&mut self) {
        self.writes = [None; CAP];
        self.len = 0;
        self.overflowed = 0;
    }

    /// Makes writes to `address` fail with [`Nack`] (or none, with `None`).
    pub fn fail(&mut self, address: Option<u8>) {
        self.fail_address = address;
    }
}

impl<const CAP: usize> FingerBoards for Recording<CAP> {
    type Error = Nack;

    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Nack> {
        self.record(board, full_or_off(outputs), None)
    }

    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Nack> {
        self.record(board, *duties, Some(*duties))
    }
}

impl<const CAP: usize> Recording<CAP> {
    fn record(
        &mut self,
        board: BoardId,
        duties: [Duty; 16],
        written: Option<[Duty; 16]>,
    ) -> Result<(), Nack> {
        if self.fail_address == Some(board.address) {
            return Err(Nack(board.address));
        }
        let outputs = on_off(&duties);
        self.outputs[board.index as usize & 15] = outputs;
        self.duties[board.index as usize & 15] = duties;
        if self.len < CAP {
            self.writes[self.len] = Some(Write {
                board,
                outputs,
                duties: written,
            });
            self.len += 1;
        } else {
            self.overflowed += 1;
        }
        Ok(())
    }
}
