//! The MIDI UART: 31250 baud 8N1 (UBRR = 15 at 8 MHz, as in the thesis), received by
//! interrupt into a ring buffer with each byte's arrival time, and every byte sent straight on
//! (soft MIDI thru) from the interrupt handlers, in order, whatever the main loop is doing.

use avr_device::atmega16::USART;
use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};

/// UBRR for 31250 baud at 8 MHz: 8 MHz / (16 · 31250) − 1.
pub const UBRR: u8 = 15;

/// 10 ms of MIDI at full speed. The main loop takes a byte in well under one byte time, so
/// the ring fills only while it is stopped (it never waits on the bus).
const RX_N: u8 = 32;
const TX_N: u8 = 16;
// Powers of two: indexes are masked, so the handlers have no bounds checks (a check's call
// would make them save every register).
const _: () = assert!(RX_N.is_power_of_two() && TX_N.is_power_of_two());

static mut RX_BUF: [u8; RX_N as usize] = [0; RX_N as usize];
/// The low 16 bits of the µs clock when each byte was taken from the UART.
static mut RX_AT: [u16; RX_N as usize] = [0; RX_N as usize];
/// Written by the receive interrupt only.
static mut RX_HEAD: u8 = 0;
/// Written by the main loop only.
static mut RX_TAIL: u8 = 0;
/// Bytes lost because the ring was full (wrapping; for a debugger).
static mut RX_LOST: u8 = 0;

// Thru: touched only by the two interrupt handlers, which never nest.
static mut TX_BUF: [u8; TX_N as usize] = [0; TX_N as usize];
static mut TX_HEAD: u8 = 0;
static mut TX_TAIL: u8 = 0;

const UDRE: u8 = 1 << 5;
const RXCIE: u8 = 1 << 7;
const UDRIE: u8 = 1 << 5;
const RXEN: u8 = 1 << 4;
const TXEN: u8 = 1 << 3;

fn usart() -> &'static avr_device::atmega16::usart::RegisterBlock {
    // SAFETY: after `start`, the registers are used by the handlers below only, and
    // UCSRB's UDRIE bit is changed only inside them.
    unsafe { &*USART::ptr() }
}

/// 31250 baud, 8N1 (UCSRC's reset value), receiver and transmitter on, receive interrupt on.
pub fn start(u: USART) {
    u.ubrrh().write(|w| unsafe { w.bits(0) });
    u.ubrrl.write(|w| unsafe { w.bits(UBRR) });
    u.ucsrb.write(|w| unsafe { w.bits(RXCIE | RXEN | TXEN) });
}

/// The next received byte, if any, with the low 16 bits of the µs clock when it arrived. With
/// one, the work probe pin is high (the caller lowers it when done).
#[inline(always)]
pub fn pop() -> Option<(u8, u16)> {
    // SAFETY: single producer (the handler writes HEAD after the byte), single consumer.
    unsafe {
        let tail = read_volatile(addr_of!(RX_TAIL));
        if tail == read_volatile(addr_of!(RX_HEAD)) {
            return None;
        }
        // A byte: the main loop's work on it starts here (its probe pin, PD4, goes high
        // before the byte leaves the ring).
        crate::probe::work(true);
        let i = (tail & (RX_N - 1)) as usize;
        let b = read_volatile(addr_of!(RX_BUF[i]));
        let at = read_volatile(addr_of!(RX_AT[i]));
        write_volatile(addr_of_mut!(RX_TAIL), (tail + 1) % RX_N);
        Some((b, at))
    }
}

#[avr_device::interrupt(atmega16)]
fn USART_RXC() {
    crate::probe::isr_enter();
    // The arrival time first: the receive-complete flag rose a few cycles ago.
    let at = crate::clock::ticks16_raw();
    let u = usart();
    // One byte each time: a second one waiting in the UART raises the interrupt again at
    // once (fewer registers to save for every byte than a loop).
    let b = u.udr.read().bits();
    // SAFETY: see the statics.
    unsafe {
        // Thru: straight out if nothing is queued and the data register is free.
        let tx_head = TX_HEAD;
        if tx_head == TX_TAIL && u.ucsra.read().bits() & UDRE != 0 {
            u.udr.write(|w| w.bits(b));
        } else {
            let next = (tx_head + 1) % TX_N;
            if next != TX_TAIL {
                TX_BUF[(tx_head & (TX_N - 1)) as usize] = b;
                TX_HEAD = next;
            }
            u.ucsrb.modify(|r, w| w.bits(r.bits() | UDRIE));
        }
        let head = read_volatile(addr_of!(RX_HEAD));
        let next = (head + 1) % RX_N;
        if next == read_volatile(addr_of!(RX_TAIL)) {
            let lost = read_volatile(addr_of!(RX_LOST));
            write_volatile(addr_of_mut!(RX_LOST), lost.wrapping_add(1));
        } else {
            let i = (head & (RX_N - 1)) as usize;
            write_volatile(addr_of_mut!(RX_BUF[i]), b);
            write_volatile(addr_of_mut!(RX_AT[i]), at);
            write_volatile(addr_of_mut!(RX_HEAD), next);
        }
    }
    crate::probe::isr_exit();
}

#[avr_device::interrupt(atmega16)]
fn USART_UDRE() {
    let u = usart();
    // SAFETY: see the statics.
    unsafe {
        if TX_HEAD != TX_TAIL {
            u.udr
                .write(|w| w.bits(TX_BUF[(TX_TAIL & (TX_N - 1)) as usize]));
            TX_TAIL = (TX_TAIL + 1) % TX_N;
        }
        if TX_HEAD == TX_TAIL {
            u.ucsrb.modify(|r, w| w.bits(r.bits() & !UDRIE));
        }
    }
}
