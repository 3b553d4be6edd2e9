//! Measurement pins for the hardware-in-the-loop tests, on pins the thesis's board leaves
//! unused (it drives only PORTB low and PD6/PD7; PORTA is free):
//!
//! - PD2 high while the UART receive handler runs, PD4 high while the main loop decodes,
//!   interprets and queues board writes, PD5 high while the TWI handler runs: the simulator
//!   counts the CPU cycles spent on a message and on a board write.
//! - PORTA: the deepest stack seen so far, in 2-byte units (saturating at 255 = 510 bytes),
//!   from a painted stack, refreshed about four times a second when idle.

use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

const PORTD: *mut u8 = 0x32 as *mut u8;
const DDRD: *mut u8 = 0x31 as *mut u8;
const PORTA: *mut u8 = 0x3B as *mut u8;
const DDRA: *mut u8 = 0x3A as *mut u8;
const SPL: *const u8 = 0x5D as *const u8;
const SPH: *const u8 = 0x5E as *const u8;

const ISR_PIN: u8 = 1 << 2;
const WORK_PIN: u8 = 1 << 4;
const TWI_PIN: u8 = 1 << 5;

/// Top of SRAM on the ATmega16.
const RAMEND: u16 = 0x045F;
const PAINT: u8 = 0xC5;

extern "C" {
    /// The end of .data/.bss/.noinit (avr-libc's linker script).
    static mut __heap_start: u8;
}

/// Makes the probe pins outputs, driven low.
pub fn init() {
    unsafe {
        write_volatile(
            PORTD,
            read_volatile(PORTD) & !(ISR_PIN | WORK_PIN | TWI_PIN),
        );
        write_volatile(DDRD, read_volatile(DDRD) | ISR_PIN | WORK_PIN | TWI_PIN);
        write_volatile(PORTA, 0);
        write_volatile(DDRA, 0xFF);
    }
}

fn sp() -> u16 {
    unsafe { u16::from_le_bytes([read_volatile(SPL), read_volatile(SPH)]) }
}

/// Fills the free SRAM between the end of the statics and the stack (minus a margin) with a
/// pattern. Call first thing, with interrupts off.
#[inline(never)]
pub fn paint_stack() {
    let start = unsafe { addr_of_mut!(__heap_start) } as u16;
    let end = sp().saturating_sub(8);
    let mut a = start;
    while a < end {
        unsafe { write_volatile(a as *mut u8, PAINT) };
        a += 1;
    }
}

/// The most stack used so far, in bytes from the top of SRAM (the main loop's own frame,
/// including everything it keeps there, counts).
pub fn stack_high_water() -> u16 {
    let mut a = unsafe { addr_of!(__heap_start) } as u16;
    while a < RAMEND && unsafe { read_volatile(a as *const u8) } == PAINT {
        a += 1;
    }
    RAMEND - a + 1
}

/// Publishes the deepest stack on PORTA.
pub fn publish() {
    let units = stack_high_water().div_ceil(2);
    unsafe { write_volatile(PORTA, units.min(255) as u8) };
}

#[inline(always)]
fn set(mask: u8, on: bool) {
    // `sbi`/`cbi`: one instruction, safe against the interrupt handler's own bit.
    unsafe {
        let v = read_volatile(PORTD);
        write_volatile(PORTD, if on { v | mask } else { v & !mask });
    }
}

#[inline(always)]
pub fn isr_enter() {
    set(ISR_PIN, true)
}
#[inline(always)]
pub fn isr_exit() {
    set(ISR_PIN, false)
}
/// Called with a constant `on`, so that it is one `sbi` or `cbi` (atomic: no interrupt can
/// come between a read and a write of PORTD).
#[inline(always)]
pub fn work(on: bool) {
    set(WORK_PIN, on)
}
#[inline(always)]
pub fn twi_enter() {
    set(TWI_PIN, true)
}
#[inline(always)]
pub fn twi_exit() {
    set(TWI_PIN, false)
}
