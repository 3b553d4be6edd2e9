//! Time from Timer1: 8 MHz / 8 = one tick a microsecond, extended past 16 bits by counting
//! overflows (every 65.536 ms) in an interrupt: a 48-bit microsecond clock, 8.9 years, of
//! which orch-core is given the low 32 bits.

use avr_device::atmega16::TC1;
use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

/// Overflows of Timer1 since power-up.
static mut OVERFLOWS: u32 = 0;

const TOV1: u8 = 1 << 2;
const TOIE1: u8 = 1 << 2;
const CS11: u8 = 1 << 1;

fn tc1() -> &'static avr_device::atmega16::tc1::RegisterBlock {
    // SAFETY: Timer1 is only read here after `start`, and written only by `start`.
    unsafe { &*TC1::ptr() }
}

/// Starts Timer1 at 1 MHz, free running, with the overflow interrupt.
pub fn start(tc: TC1) {
    tc.tccr1a.write(|w| unsafe { w.bits(0) });
    tc.tcnt1.write(|w| unsafe { w.bits(0) });
    tc.tccr1b.write(|w| unsafe { w.bits(CS11) });
    tc.timsk.modify(|r, w| unsafe { w.bits(r.bits() | TOIE1) });
}

/// The low 16 bits of the clock (µs), with interrupts off: an interrupt handler that reads
/// TCNT1 between the two byte reads would change Timer1's shared TEMP register. Use it in
/// interrupt handlers and critical sections.
#[inline(always)]
pub fn ticks16_raw() -> u16 {
    tc1().tcnt1.read().bits()
}

/// The overflow count and Timer1, read together (interrupts off).
#[inline(always)]
fn read() -> (u32, u16) {
    avr_device::interrupt::free(|_| {
        let t = tc1().tcnt1.read().bits();
        // SAFETY: interrupts are off, so the overflow handler cannot run meanwhile.
        let mut ovf = unsafe { read_volatile(addr_of!(OVERFLOWS)) };
        // An overflow that happened after interrupts went off is still pending.
        if tc1().tifr.read().bits() & TOV1 != 0 && t < 0x8000 {
            ovf = ovf.wrapping_add(1);
        }
        (ovf, t)
    })
}

/// Microseconds since power-up, the low 32 bits (orch-core's `*_low32` methods).
#[inline(always)]
pub fn now_us() -> u32 {
    let (ovf, t) = read();
    (ovf << 16) | t as u32
}

/// The low 32 bits of the time of a stamp taken at most 65 ms ago (the low 16 bits of the
/// clock then). A stamp older than that (the main loop stalled) comes out up to 65 ms late,
/// never in the future. Built from the overflow count (one less if Timer1 has wrapped since
/// the stamp).
#[inline(always)]
pub fn since(stamp: u16) -> u32 {
    let (ovf, t) = read();
    let ovf = if t < stamp { ovf.wrapping_sub(1) } else { ovf };
    (ovf << 16) | stamp as u32
}

#[avr_device::interrupt(atmega16)]
fn TIMER1_OVF() {
    // SAFETY: the only writer; the reader masks interrupts.
    unsafe {
        let p = addr_of_mut!(OVERFLOWS);
        write_volatile(p, read_volatile(p).wrapping_add(1));
    }
}
