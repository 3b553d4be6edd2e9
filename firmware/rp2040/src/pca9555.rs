//! The default build's finger boards: the thesis's four PCA9555s at 0x21..=0x24, on/off.
//!
//! Each board is initialised outputs 0 FIRST, THEN all pins outputs (orch-boards'
//! `Pca9555Async::init`), and a changed board gets one `[0x02, lo, hi]` write. `main.rs` runs
//! the attempts, the time limits and the retry rounds the same way for either kind of board.

use core::convert::Infallible;

use orch_boards::asynch::Pca9555Async;
use orch_core::{BoardId, FingerBoards, Interpreter};
use static_cell::ConstStaticCell;

use crate::bus::{self, Fault};
use crate::BusDevice;

/// The boards' 7-bit addresses (the thesis's 0x42..0x48 in write form).
pub const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];

/// How many boards.
pub const BOARDS: usize = 4;

/// The interpreter: the thesis's (four boards, 61 keys).
pub type Robot = Interpreter;

/// What one board is sent: its 16 outputs.
pub type Frame = u16;

/// The interpreter: `Interpreter::thesis()` (61 keys, four boards, fold, guard on), in a
/// static (≈ 1.2 KB) built at compile time: never on the stack.
pub fn robot() -> &'static mut Robot {
    static ROBOT: ConstStaticCell<Interpreter> = ConstStaticCell::new(Interpreter::thesis());
    ROBOT.take()
}

/// The four boards.
pub struct Boards([Pca9555Async<BusDevice>; BOARDS]);

impl Boards {
    /// The boards, each on `device()`. Does no bus traffic.
    pub fn new(mut device: impl FnMut() -> BusDevice) -> Self {
        Self(ADDRESSES.map(|a| Pca9555Async::new(device(), a)))
    }

    /// Board `i` initialised: outputs 0 FIRST, THEN all pins outputs.
    pub async fn init(&mut self, i: usize) -> Result<(), Fault> {
        bus::within(self.0[i].init()).await
    }

    /// Board `i` sent `frame`: one `[0x02, lo, hi]` write.
    pub async fn set(&mut self, i: usize, frame: &Frame) -> Result<(), Fault> {
        bus::within(self.0[i].set_outputs(*frame)).await
    }

    /// Which boards are in service (bit `i`: board `i` is not): nothing to do with it here.
    pub fn in_service(&mut self, _failed: u8) {}
}

/// The frame's changed boards, as orch-core's flush hands them over (it takes them as
/// written; the async writes follow).
pub fn changed(robot: &mut Robot) -> [Option<Frame>; BOARDS] {
    let mut changed = Changed::default();
    let _ = robot.flush(&mut changed);
    changed.0
}

/// Board `i`'s frame now, for a board initialised again.
pub fn frame(robot: &Robot, i: usize) -> Frame {
    robot.frame().outputs(i)
}

/// Whether `frame` has every key up (an initialised board already shows it).
pub fn is_off(frame: &Frame) -> bool {
    *frame == 0
}

/// For the panic handler: every board's outputs to 0 now (`[0x02, 0x00, 0x00]`).
pub fn release_all_now() {
    bus::write_all_now(&ADDRESSES, &[0x02, 0x00, 0x00]);
}

#[derive(Default)]
struct Changed([Option<u16>; BOARDS]);

impl FingerBoards for Changed {
    type Error = Infallible;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Infallible> {
        if let Some(slot) = self.0.get_mut(board.index as usize) {
            *slot = Some(outputs);
        }
        Ok(())
    }
}
