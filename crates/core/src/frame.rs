//! The finger frame: what every output of every board should be, and which boards changed.

use crate::bits::bit16;
use crate::keymap::Layout;
use crate::output::{BoardId, FingerBoards};

/// `B` boards × 16 outputs, with a dirty flag per board.
///
/// A board is dirty when its outputs differ from what was last written to it, so a key that
/// goes down and back up between two flushes costs no bus write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FingerFrame<const B: usize> {
    outputs: [u16; B],
    written: [u16; B],
}

/// A board write failed; the board stays dirty so the next flush tries again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlushError<E> {
    /// The board that failed.
    pub board: BoardId,
    /// What its driver reported.
    pub error: E,
}

impl<const B: usize> Default for FingerFrame<B> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const B: usize> FingerFrame<B> {
    /// Every output off, and every board taken as written with 0 (as after initialisation).
    pub const fn new() -> Self {
        Self {
            outputs: [0; B],
            written: [0; B],
        }
    }

    /// The wanted outputs of `board`.
    pub fn outputs(&self, board: usize) -> u16 {
        self.outputs[board]
    }

    /// The wanted outputs of every board.
    pub fn all(&self) -> &[u16; B] {
        &self.outputs
    }

    /// Whether `board` differs from what was last written to it.
    pub fn is_dirty(&self, board: usize) -> bool {
        self.outputs[board] != self.written[board]
    }

    /// Whether output `bit` of `board` was on in the last write to that board.
    pub fn is_written(&self, board: u8, bit: u8) -> bool {
        self.written[board as usize] & bit16(bit) != 0
    }

    /// Whether any board needs a write.
    pub fn any_dirty(&self) -> bool {
        self.outputs != self.written
    }

    /// Sets or clears one output.
    pub fn set(&mut self, board: u8, bit: u8, on: bool) {
        let mask = bit16(bit);
        let word = &mut self.outputs[board as usize];
        if on {
            *word |= mask;
        } else {
            *word &= !mask;
        }
    }

    /// Turns every output off (the boards become dirty where they were not already off).
    pub fn clear(&mut self) {
        self.outputs = [0; B];
    }

    /// Marks every board as unknown, so the next flush writes all of them (after a bus error
    /// or a board reset, when what the board holds is no longer known).
    pub fn invalidate(&mut self) {
        for (w, o) in self.written.iter_mut().zip(self.outputs.iter()) {
            *w = !*o;
        }
    }

    /// Writes every dirty board, in board order, one write each. Returns how many boards were
    /// written. On the first failure it stops; that board and the ones after it stay dirty.
    pub fn flush<O: FingerBoards>(
        &mut self,
        layout: &Layout<B>,
        out: &mut O,
    ) -> Result<u8, FlushError<O::Error>> {
        let mut n = 0;
        for board in 0..B {
            if self.outputs[board] == self.written[board] {
                continue;
            }
            let id = BoardId {
                index: board as u8,
                address: layout.boards[board].address,
            };
            out.write_board(id, self.outputs[board])
                .map_err(|error| FlushError { board: id, error })?;
            self.written[board] = self.outputs[board];
            n += 1;
        }
        Ok(n)
    }
}
