//! The one output trait: where finger frames go.
//!
//! Real boards (`orch-boards`), the virtual robot and the [`Recording`](crate::Recording) test
//! double all implement [`FingerBoards`]. The interpreter never talks to a bus itself; the caller
//! hands its frame to an implementation with [`FingerFrame::flush`](crate::FingerFrame::flush).

use crate::dynamics::Duty;

/// Which finger board a write is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BoardId {
    /// Index of the board in the layout, 0-based.
    pub index: u8,
    /// The board's 7-bit I2C address.
    pub address: u8,
}

/// What a finger board drives its 16 outputs with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BoardKind {
    /// On or off (a PCA9555 or TCA9555 I/O expander): velocity is ignored, a key is at full
    /// power while down.
    #[default]
    OnOff,
    /// A PWM duty per output (a PCA9685): velocity is strike strength
    /// ([`dynamics`](crate::dynamics)), written with
    /// [`write_duties`](FingerBoards::write_duties).
    Pwm,
}

/// A set of finger boards, each with 16 outputs.
pub trait FingerBoards {
    /// What can go wrong while writing a board.
    type Error;

    /// Sets all 16 outputs of one board at once: bit `n` is output `n`; bits 0..=7 are port 0
    /// and bits 8..=15 are port 1. A 1 energises the solenoid (finger down).
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error>;

    /// Sets the duties of all 16 outputs of one PWM board at once (output `n` gets
    /// `duties[n]`), for [`Interpreter::flush_duties`](crate::Interpreter::flush_duties).
    ///
    /// The default is for an on/off board: every output with a duty above 0 on, through
    /// [`write_board`](Self::write_board). A PWM board (or a set that mixes kinds, for its PWM
    /// boards) writes the duties.
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Self::Error> {
        self.write_board(board, on_off(duties))
    }
}

/// On/off `outputs` as duties: [`Duty::FULL`] where bit `n` is set, [`Duty::OFF`] where not
/// (the inverse of [`on_off`]).
pub fn full_or_off(outputs: u16) -> [Duty; 16] {
    core::array::from_fn(|n| {
        if outputs & (1 << n) != 0 {
            Duty::FULL
        } else {
            Duty::OFF
        }
    })
}

/// The on/off outputs of `duties`: bit `n` set where `duties[n]` is above 0.
pub fn on_off(duties: &[Duty; 16]) -> u16 {
    duties
        .iter()
        .enumerate()
        .fold(0, |m, (n, d)| if *d > Duty::OFF { m | 1 << n } else { m })
}

impl<T: FingerBoards + ?Sized> FingerBoards for &mut T {
    type Error = T::Error;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        (**self).write_board(board, outputs)
    }
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Self::Error> {
        (**self).write_duties(board, duties)
    }
}
