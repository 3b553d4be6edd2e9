//! A board driver on a Linux I2C bus: four PCA9555 finger boards (0x21..=0x24) set up, middle C
//! pressed for 100 ms and released.
//!
//! The drivers take any `embedded_hal::i2c::I2c`: on a Raspberry Pi that is
//! `linux_embedded_hal::I2cdev` on `/dev/i2c-1`; on a microcontroller, its HAL's bus. Without
//! a device named, the bus here is `Shown`, which prints each write instead of sending it.
//!
//! `cargo run -p orch-boards --example linux_bus [-- /dev/i2c-1]`

use std::error::Error;
use std::time::Duration;

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, Operation, SevenBitAddress};
use orch_boards::FingerBoardSet;
use orch_core::{BoardId, FingerBoards};

fn main() -> Result<(), Box<dyn Error>> {
    match std::env::args().nth(1) {
        Some(device) => press_middle_c(linux_embedded_hal::I2cdev::new(device)?),
        None => press_middle_c(Shown),
    }
}

fn press_middle_c<B: I2c>(bus: B) -> Result<(), Box<dyn Error>>
where
    B::Error: 'static,
{
    let mut boards = FingerBoardSet::new(bus, [0x21, 0x22, 0x23, 0x24]);
    // Each board's outputs to 0 first, then its pins made outputs: no solenoid fires.
    boards.init()?;
    // Key 60 − 36 = 24: board 1, bit 8 (port 1). One write of both ports.
    let board = BoardId {
        index: 1,
        address: 0x22,
    };
    boards.write_board(board, 1 << 8)?;
    std::thread::sleep(Duration::from_millis(100));
    boards.write_board(board, 0)?;
    Ok(())
}

/// A bus that prints each write: `0x22: [02, 00, 01]` is register 0x02 (output port 0), then
/// port 0's and port 1's bits.
struct Shown;

impl ErrorType for Shown {
    type Error = ErrorKind;
}

impl I2c<SevenBitAddress> for Shown {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        for op in ops {
            if let Operation::Write(bytes) = op {
                println!("0x{address:02X}: {bytes:02X?}");
            }
        }
        Ok(())
    }
}
