//! orch on the thesis's own board: an ATmega16 at 8 MHz.
//!
//! - MIDI in on the UART at 31250 baud (UBRR 15), by interrupt into a ring buffer; every byte
//!   is sent on at once on the UART's TX pin (soft MIDI thru), as the thesis's board passed
//!   its stream on to the flute robot.
//! - orch-core's decoder, interpreter and safety guard (`Interpreter<4, 61, NotePool<32>,
//!   Thesis>`: the thesis's keyboard and configuration, as constants), with time from Timer1
//!   (1 µs ticks).
//! - The four PCA9555 finger boards at 0x21..=0x24 on the TWI (83.33 kHz as in the thesis, or
//!   up to 222 kHz: `ORCH_TWI_HZ` at build time),
//!   interrupt-driven: writes are queued and go out while the main loop decodes the next
//!   bytes, with timeouts, bus recovery and retries. A board is written only when its bits
//!   change, in one transaction.
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
use orch_core::{BoardId, FingerBoards, Interpreter, NotePool, Thesis};

/// How often boards that failed are initialised and written again.
const RETRY_US: u32 = 10_000;

type Robot = Interpreter<4, 61, NotePool<32>, Thesis>;

/// The boards as the interpreter's frame sees them: each write is queued for the TWI handler
/// (the frame takes it as written). A board set aside after failing [`twi::ATTEMPTS`] times
/// is skipped; the main loop initialises it again later and writes its whole frame.
struct Boards;

impl FingerBoards for Boards {
    type Error = Infallible;

    #[inline(always)]
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Infallible> {
        if twi::failed() & twi::board_bit(board.index) == 0 {
            twi::push(board.index, twi::OUTPUTS, outputs);
        }
        Ok(())
    }
}

/// Each board: outputs 0 FIRST, THEN all pins outputs (a failed first write drops the
/// second: the pins stay inputs), then `outputs` if any is on.
fn init_board(board: u8, outputs: u16) {
    twi::push(board, twi::OUTPUTS, 0);
    twi::push(board, twi::CONFIGURATION, 0);
    if outputs != 0 {
        twi::push(board, twi::OUTPUTS, outputs);
    }
}

/// The interpreter (536 bytes) lives in a static built at compile time: built at run time it
/// would pass through the stack, twice its size in 1 KB of SRAM. With the configuration a
/// constant ([`Thesis`]) its initial state is all zero bits, so it sits in `.bss`: no flash for
/// an initial copy.
static mut ROBOT: Robot = Robot::thesis_fixed();

#[avr_device::entry]
fn main() -> ! {
    probe::paint_stack();
    // SAFETY: first and only call.
    let dp = unsafe { Peripherals::steal() };

    // JTAG off: JTD must be written twice within four cycles.
    let mcucsr = dp.CPU.mcucsr.read().bits() | 0x80;
    dp.CPU.mcucsr.write(|w| unsafe { w.bits(mcucsr) });
    dp.CPU.mcucsr.write(|w| unsafe { w.bits(mcucsr) });

    // Watchdog on, about 0.52 s (WDP2 | WDP0). Through the timed sequence (WDTOE | WDE, then
    // the value within four cycles): the ATmega16 takes the prescaler either way, but simavr
    // keeps WDP at 0 (16 ms) unless it comes this way.
    avr_device::asm::wdr();
    dp.WDT
        .wdtcr
        .write(|w| unsafe { w.bits((1 << 4) | (1 << 3)) });
    dp.WDT.wdtcr.write(|w| unsafe { w.bits((1 << 3) | 0b101) });

    // The thesis's MOSFET port: all outputs, all low.
    dp.PORTB.portb.write(|w| unsafe { w.bits(0) });
    dp.PORTB.ddrb.write(|w| unsafe { w.bits(0xFF) });
    probe::init();

    clock::start(dp.TC1);
    midi::start(dp.USART);
    twi::start(dp.TWI, dp.PORTC);

    // SAFETY: the only reference to ROBOT; the interrupt handlers never touch it.
    let robot = unsafe { &mut *addr_of_mut!(ROBOT) };

    // Boards: outputs 0 first, then all pins outputs, one board after another; the TWI
    // handler sends them once interrupts are on. A board that does not answer keeps its
    // pins as inputs and is tried again in the loop.
    for i in 0..4u8 {
        init_board(i, 0);
    }
    // Every time in the loop is the low 32 bits of the µs clock, compared by wrapping
    // difference (they are at most 250 ms ahead), and orch-core is given the same: its
    // `*_low32` methods keep a byte's time arithmetic 32-bit.
    let mut retry_at = RETRY_US;
    let mut publish_at = 0u32;
    // The guard's next deadline, asked again after every call that may move it: the loop
    // compares times with it, and asks orch-core only after feeding a byte that completed a
    // message or running a timer, once the write it made is on its way.
    let mut deadline: Option<u32> = None;

    // SAFETY: everything the handlers use is set up.
    unsafe { avr_device::interrupt::enable() };

    loop {
        avr_device::asm::wdr();
        twi::check();
        // (The work probe pin goes high inside `pop`, before the byte leaves the ring.)
        if let Some((byte, stamp)) = midi::pop() {
            let at = clock::since(stamp);
            // The guard's timers that fall before this byte first, each at its own time,
            // then the byte at its arrival time: the same steps, at the same times, as
            // orch-core on a host fed the same bytes.
            while let Some(d) = deadline {
                if !reached(at, d) {
                    break;
                }
                tick(robot, d);
                deadline = next_deadline(robot);
            }
            // Most bytes only begin or continue a message: the frame and the deadline are as
            // they were.
            if robot.feed_low32(byte, at) {
                flush(robot);
                deadline = next_deadline(robot);
            }
            // A note message waiting for its last byte: its board addressed on the bus while
            // that byte is on the wire (or the transaction ended, if it wrote nothing).
            twi::ahead(robot.board_ahead().map(|b| b.index));
            probe::work(false);
            continue;
        }
        let now = clock::now_us();
        if let Some(d) = deadline {
            if reached(now, d) {
                probe::work(true);
                tick(robot, d);
                deadline = next_deadline(robot);
                probe::work(false);
            }
        }
        let failed = twi::failed();
        if failed != 0 && reached(now, retry_at) && twi::idle() {
            // Whatever a board holds after coming back, it gets the frame's outputs again.
            for i in 0..4u8 {
                if failed & twi::board_bit(i) != 0 {
                    twi::clear_failed(i);
                    init_board(i, robot.frame().outputs(i as usize));
                }
            }
            retry_at = now.wrapping_add(RETRY_US);
        }
        if reached(now, publish_at) {
            probe::publish();
            publish_at = now.wrapping_add(250_000);
            // orch-core's 32-bit time needs a call at least every 2³⁰ µs (17.8 minutes): a
            // silent line with no key down makes none, so the clock is shown to it here, when
            // no timer is due (those run above, one a turn, each at its own time).
            if deadline.is_none_or(|d| !reached(now, d)) {
                tick(robot, now);
                deadline = next_deadline(robot);
            }
        }
    }
}

/// The guard's next deadline (the low 32 bits of the µs clock). Out of line: asked at four
/// places in the loop, ≈ 170 bytes of flash less than inlined four times, for a call on a
/// message that completes.
#[inline(never)]
fn next_deadline(robot: &Robot) -> Option<u32> {
    robot.next_deadline_low32()
}

/// Whether `now`, the low 32 bits of the µs clock, is at or past `at` (less than 35 minutes
/// apart either way).
#[inline(always)]
fn reached(now: u32, at: u32) -> bool {
    (now.wrapping_sub(at) as i32) >= 0
}

/// Runs the guard's timers at `at` (the low 32 bits of the µs clock) and queues what they
/// changed.
#[inline(never)]
fn tick(robot: &mut Robot, at: u32) {
    if robot.tick_low32(at) {
        flush(robot);
    }
}

/// Queues the boards that changed. Most messages change none: the check is inline, one
/// byte's compare (the boards touched since the last flush); orch-core's flush, which visits
/// those boards and writes the dirty ones, only when one was.
#[inline(always)]
fn flush(robot: &mut Robot) {
    if robot.frame().touched() {
        flush_dirty(robot);
    }
}

#[inline(never)]
fn flush_dirty(robot: &mut Robot) {
    let _ = robot.flush(&mut Boards);
}

/// Where every panic ends (`-Cpanic=immediate-abort` makes each one a call to `abort`; this
/// definition takes over from the weak endless loop the toolchain links in): every key is let
/// go at once, with interrupts off, by polled writes of outputs 0 after the bus is freed
/// ([`twi::release_all_now`]: 1.4 ms in simavr, ≈ 2 ms on a real bus at 83.33 kHz); then the
/// watchdog, reset no more, resets the MCU within its 0.5 s, and power-up initialises every
/// board with all keys up. Before, the keys held at a panic stayed down until that reset.
#[no_mangle]
pub extern "C" fn abort() -> ! {
    avr_device::interrupt::disable();
    twi::release_all_now();
    // Waiting for the watchdog: nothing else runs again.
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // Not reached with `-Cpanic=immediate-abort` (each panic calls `abort`); kept for a build
    // without it.
    abort()
}
