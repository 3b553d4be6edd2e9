//! The one output trait: where finger frames go.
//!
//! Real boards (`orch-boards`), the virtual robot and the [`Recording`](crate::Recording) test
//! double all implement [`FingerBoards`]. The interpreter never talks to a bus itself; the caller
//! hands its frame to an implementation with [`FingerFrame::flush`](crate::FingerFrame::flush).

/// Which finger board a write is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BoardId {
    /// Index of the board in the layout, 0-based.
    pub index: u8,
    /// The board's 7-bit I2C address.
    pub address: u8,
}

/// A set of finger boards, each with 16 outputs.
pub trait FingerBoards {
    /// What can go wrong while writing a board.
    type Error;

    /// Sets all 16 outputs of one board at once: bit `n` is output `n`; bits 0..=7 are port 0
    /// and bits 8..=15 are port 1. A 1 energises the solenoid (finger down).
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error>;
}

impl<T: FingerBoards + ?Sized> FingerBoards for &mut T {
    type Error = T::Error;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        (**self).write_board(board, outputs)
    }
}
