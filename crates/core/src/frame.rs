//! The finger frame: what every output of every board should be, and which boards changed.

use crate::bits::bit16;
use crate::keymap::Layout;
use crate::output::{BoardId, FingerBoards};

/// `B` boards (at most 16) × 16 outputs, with a dirty flag per board.
///
/// A board is dirty when its outputs differ from what was last written to it, so a key that
/// goes down and back up between two flushes costs no bus write.
///
/// Two frames are equal when their outputs and what was written are: which boards were
/// touched since the last flush ([`touched`](Self::touched)) is bookkeeping, not state.
#[derive(Clone, Copy, Debug)]
pub struct FingerFrame<const B: usize> {
    outputs: [u16; B],
    written: [u16; B],
    /// One bit a board whose outputs were set or cleared since the last flush: the boards
    /// [`flush`](Self::flush) visits (it writes those that are dirty).
    touched: u16,
}

impl<const B: usize> PartialEq for FingerFrame<B> {
    fn eq(&self, other: &Self) -> bool {
        self.outputs == other.outputs && self.written == other.written
    }
}

impl<const B: usize> Eq for FingerFrame<B> {}

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
        assert!(B <= 16, "a frame has at most 16 boards");
        Self {
            outputs: [0; B],
            written: [0; B],
            touched: 0,
        }
    }

    /// Whether any board was touched since the last flush: `false` means that
    /// [`flush`](Self::flush) has nothing to write; `true`, that it may have (a key pressed and
    /// released in between leaves its board touched but not dirty). One load and compare,
    /// for a firmware that checks after every message.
    #[inline(always)]
    pub fn touched(&self) -> bool {
        self.touched != 0
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
    #[inline]
    pub fn set(&mut self, board: u8, bit: u8, on: bool) {
        let mask = bit16(bit);
        self.touched |= bit16(board);
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
        self.touched = Self::ALL;
    }

    /// Every board's bit in [`touched`](Self::touched).
    const ALL: u16 = if B >= 16 { u16::MAX } else { (1 << B) - 1 };

    /// Marks every board as unknown, so the next flush writes all of them (after a bus error
    /// or a board reset, when what the board holds is no longer known).
    pub fn invalidate(&mut self) {
        for (w, o) in self.written.iter_mut().zip(self.outputs.iter()) {
            *w = !*o;
        }
        self.touched = Self::ALL;
    }

    /// Takes `board` as written with its wanted outputs (by a write made elsewhere: the
    /// interpreter's duty flush).
    #[cfg(feature = "dynamics")]
    pub(crate) fn mark_written(&mut self, board: usize) {
        self.written[board] = self.outputs[board];
    }

    /// Forgets which boards were touched (after a flush that visited every board).
    #[cfg(feature = "dynamics")]
    pub(crate) fn untouch(&mut self) {
        self.touched = 0;
    }

    /// Writes every dirty board, in board order, one write each. Returns how many boards were
    /// written. On the first failure it stops; that board and the ones after it stay dirty.
    pub fn flush<O: FingerBoards>(
        &mut self,
        layout: &Layout<B>,
        out: &mut O,
    ) -> Result<u8, FlushError<O::Error>> {
        let mut n = 0;
        // Only the boards touched since the last flush can be dirty: one bit each, shifted
        // out one board at a time (a constant shift, cheap on an 8-bit MCU).
        let mut touched = self.touched;
        self.touched = 0;
        let mut board = 0;
        while touched != 0 {
            if touched & 1 != 0 && self.outputs[board] != self.written[board] {
                let id = BoardId {
                    index: board as u8,
                    address: layout.boards[board].address,
                };
                if let Err(error) = out.write_board(id, self.outputs[board]) {
                    // This board and the ones after it are still to be written.
                    self.touched |= touched << board;
                    return Err(FlushError { board: id, error });
                }
                self.written[board] = self.outputs[board];
                n += 1;
            }
            touched >>= 1;
            board += 1;
        }
        Ok(n)
    }
}
