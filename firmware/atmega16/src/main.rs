//! orch on the thesis's own board: an ATmega16 at 8 MHz.
//!
//! - MIDI in on the UART at 31250 baud (UBRR 15), by interrupt into a ring buffer; every byte
//!   is sent on at once on the UART's TX pin (soft MIDI thru), as the thesis's board passed
//!   its stream on to the flute robot.
//! - orch-core's decoder, interpreter and safety guard (`Interpreter<4, 61, NotePool<32>>`,
//!   the thesis's keyboard), with time from Timer1 (1 µs ticks).
//! - The four PCA9555 finger boards at 0x21..=0x24 through orch-boards' `FingerBoardSet`, on an
//!   embedded-hal `I2c` over the TWI (83.33 kHz, as in the thesis) with timeouts, bus recovery
//!   and retries. A board is written only when its bits change, in one transaction.
//! - The watchdog (0.5 s): a hung firmware resets, and power-up releases every key.
//! - JTAG off (JTD written twice), so that PORTC is free for the TWI.
//! - Power-up: each board gets outputs 0 FIRST, THEN all pins outputs (the driver's safe
//!   order): no solenoid is driven before the first note.
#![no_std]
#![no_main]
#![feature(abi_avr_interrupt)]
#![allow(unused_unsafe)]

mod clock;
mod midi;
mod probe;
mod twi;

use core::convert::Infallible;
use core::ptr::addr_of_mut;

use avr_device::atmega16::Peripherals;
use orch_boards::FingerBoardSet;
use orch_core::{BoardId, FingerBoards, Instant, Interpreter, NotePool};

use twi::Twi;

/// The boards' 7-bit addresses (the thesis's 0x42..0x48 in write form).
const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];
/// Attempts per board write before the board is set aside until the next retry round.
const ATTEMPTS: u8 = 3;
/// How often boards that failed are initialised and written again.
const RETRY_US: u64 = 10_000;

type Robot = Interpreter<4, 61, NotePool<32>>;
type Boards = FingerBoardSet<Twi, 4>;

/// The boards as the interpreter's frame sees them: a board that fails [`ATTEMPTS`] times is
/// marked in `failed` and skipped (the frame takes it as written); the main loop initialises
/// it again later and writes the whole frame.
struct Tolerant<'a> {
    set: &'a mut Boards,
    failed: &'a mut u8,
}

impl FingerBoards for Tolerant<'_> {
    type Error = Infallible;

    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Infallible> {
        let bit = 1u8 << (board.index & 7);
        if *self.failed & bit != 0 {
            return Ok(());
        }
        for _ in 0..ATTEMPTS {
            if self.set.write_board(board, outputs).is_ok() {
                return Ok(());
            }
            avr_device::asm::wdr();
        }
        *self.failed |= bit;
        Ok(())
    }
}

/// The interpreter (about 630 bytes) lives in a static built at compile time: built at run
/// time it would pass through the stack, twice its size in 1 KB of SRAM.
static mut ROBOT: Robot = Robot::thesis_with();

#[avr_device::entry]
fn main() -> ! {
    probe::paint_stack();
    // SAFETY: first and only call.
    let dp = unsafe { Peripherals::steal() };

    // JTAG off: JTD must be written twice within four cycles.
    let mcucsr = dp.CPU.mcucsr.read().bits() | 0x80;
    dp.CPU.mcucsr.write(|w| unsafe { w.bits(mcucsr) });
    dp.CPU.mcucsr.write(|w| unsafe { w.bits(mcucsr) });

    // Watchdog on, about 0.52 s (WDP2 | WDP0).
    avr_device::asm::wdr();
    dp.WDT.wdtcr.write(|w| unsafe { w.bits((1 << 3) | 0b101) });

    // The thesis's MOSFET port: all outputs, all low.
    dp.PORTB.portb.write(|w| unsafe { w.bits(0) });
    dp.PORTB.ddrb.write(|w| unsafe { w.bits(0xFF) });
    probe::init();

    clock::start(dp.TC1);
    midi::start(dp.USART);
    let mut boards: Boards = FingerBoardSet::new(Twi::new(dp.TWI, dp.PORTC), ADDRESSES);

    // SAFETY: the only reference to ROBOT; the interrupt handlers never touch it.
    let robot = unsafe { &mut *addr_of_mut!(ROBOT) };

    // Boards: outputs 0 first, then all pins outputs, one board at a time; a board that does
    // not answer keeps its pins as inputs and is tried again in the loop.
    let mut failed: u8 = 0;
    for i in 0..4u8 {
        if boards.init_board(i).is_err() {
            failed |= 1 << i;
        }
    }
    let mut retry_at = clock::now_us() + RETRY_US;
    let mut publish_at = 0u64;

    // SAFETY: everything the handlers use is set up.
    unsafe { avr_device::interrupt::enable() };

    loop {
        avr_device::asm::wdr();
        if midi::pending() {
            probe::work(true);
            while let Some(byte) = midi::pop() {
                robot.feed(byte, Instant::from_micros(clock::now_us()));
            }
            probe::work(false);
        }
        let now = clock::now_us();
        if robot.next_deadline().is_some_and(|d| d.as_micros() <= now) {
            probe::work(true);
            robot.tick(Instant::from_micros(now));
            probe::work(false);
        }
        if robot.frame().any_dirty() {
            probe::flushing(true);
            let _ = robot.flush(&mut Tolerant {
                set: &mut boards,
                failed: &mut failed,
            });
            probe::flushing(false);
        }
        if failed != 0 && now >= retry_at {
            probe::flushing(true);
            for i in 0..4u8 {
                if failed & (1 << i) != 0 && boards.init_board(i).is_ok() {
                    failed &= !(1 << i);
                }
            }
            // Whatever a recovered board holds now, the whole frame goes out again (boards
            // whose driver cache already matches are not written).
            robot.frame_mut().invalidate();
            let _ = robot.flush(&mut Tolerant {
                set: &mut boards,
                failed: &mut failed,
            });
            retry_at = clock::now_us() + RETRY_US;
            probe::flushing(false);
        }
        if now >= publish_at && !midi::pending() {
            probe::publish();
            publish_at = now + 250_000;
        }
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // The watchdog resets the board, and power-up releases every key.
    avr_device::interrupt::disable();
    loop {}
}
