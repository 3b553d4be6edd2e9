//! The TWI master, interrupt-driven: board writes go into a queue and the TWI interrupt puts
//! them on the bus one after another, while the main loop goes on decoding MIDI. Every write
//! is one transaction `[register, lo, hi]` to one PCA9555.
//!
//! - Clock: [`TWI_HZ`], chosen at build time (`ORCH_TWI_HZ`); TWBR and the prescaler follow.
//! - A NACK or a lost arbitration tries the write again, [`ATTEMPTS`] times in all; a board
//!   that still fails is marked in [`failed`], its queued writes are dropped (they are never
//!   sent out of order, and an initialisation's configuration write never follows a failed
//!   output write), and the main loop initialises it again later.
//! - No step may take longer than [`STEP_TIMEOUT_US`] (the thesis waited for ever): the main
//!   loop calls [`check`], which frees a stuck bus (TWI off, SCL clocked by hand until SDA is
//!   free, a STOP, TWI on) and counts a failed attempt.
//! - Addressing ahead ([`ahead`]): while the last byte of a note message is still on the MIDI
//!   wire, the bus is idle and the note's board is known, the START, the board's address and
//!   the output register go out and the bus is held (SCL low) until the outputs come
//!   ([`push`]); if the message turns out to change nothing on that board (the guard dropped
//!   the note, a Note-Off ended no note), or anything else needs the bus first, the
//!   transaction ends there with a STOP: a write of the register byte alone, which changes no
//!   register. So of a write's 38 bit times only the two data bytes and the STOP come after
//!   the last MIDI byte.

use avr_device::atmega16::{PORTC, TWI};
use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};
use orch_boards::registers::{CONFIGURATION_0, OUTPUT_PORT_0};

use crate::clock;

/// The bus clock in Hz, chosen at build time: the `ORCH_TWI_HZ` environment variable (decimal,
/// `_` allowed), whose default, the thesis's 83 333 Hz, is set in `.cargo/config.toml`'s
/// `[env]` (an `ORCH_TWI_HZ` in the environment wins). Cargo rebuilds when it changes.
/// From 10 kHz (below it one byte, 9 bit times, outlasts [`STEP_TIMEOUT_US`]) up to the fastest the ATmega16 datasheet allows a master at 8 MHz: it asks for
/// TWBR ≥ 10, and SCL = F_CPU / (16 + 2 · TWBR · 4^TWPS), so 8 MHz / 36 = 222 222 Hz. TWBR and
/// the prescaler follow ([`TWBR`], [`TWPS`]); a value out of range does not build.
pub const TWI_HZ: u32 = parse_hz(env!("ORCH_TWI_HZ"));

/// The fastest bus clock the datasheet allows at 8 MHz (TWBR = 10, prescaler 1).
pub const TWI_HZ_MAX: u32 = F_CPU / (16 + 2 * 10);

const F_CPU: u32 = 8_000_000;

/// `ORCH_TWI_HZ`'s digits as a number, at compile time.
const fn parse_hz(s: &str) -> u32 {
    let b = s.as_bytes();
    assert!(!b.is_empty(), "ORCH_TWI_HZ: a number of Hz");
    let mut v: u32 = 0;
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'0'..=b'9' => {
                assert!(v <= (u32::MAX - 9) / 10, "ORCH_TWI_HZ: too large");
                v = v * 10 + (b[i] - b'0') as u32;
            }
            b'_' => {}
            _ => panic!("ORCH_TWI_HZ: decimal digits only"),
        }
        i += 1;
    }
    v
}

/// (TWBR, TWPS) for [`TWI_HZ`]: SCL = F_CPU / (16 + 2 · TWBR · 4^TWPS).
const BIT_RATE: (u8, u8) = {
    assert!(
        TWI_HZ >= 10_000 && TWI_HZ <= TWI_HZ_MAX,
        "ORCH_TWI_HZ: 10000 ..= 222222 (the ATmega16 datasheet: TWBR >= 10 in master mode)"
    );
    let divider = (F_CPU + TWI_HZ / 2) / TWI_HZ;
    let x = (divider - 16) / 2; // TWBR · 4^TWPS
    let mut twps = 0;
    while x >> (2 * twps) > 255 {
        twps += 1;
    }
    assert!(twps <= 3);
    let twbr = x >> (2 * twps);
    assert!(
        twbr >= 10,
        "ORCH_TWI_HZ: TWBR would be below the datasheet's 10"
    );
    (twbr as u8, twps as u8)
};
/// TWBR (40 at 83.33 kHz: 8 MHz / 96).
pub const TWBR: u8 = BIT_RATE.0;
/// The prescaler bits (0: prescaler 1).
pub const TWPS: u8 = BIT_RATE.1;

/// Attempts per write before the board is set aside.
pub const ATTEMPTS: u8 = 3;
/// The longest a bus step (START, a byte and its acknowledge) may take: a byte takes 108 µs
/// at 83.33 kHz, so 1 ms means the bus is stuck.
pub const STEP_TIMEOUT_US: u16 = 1000;
/// Half an SCL period while recovering the bus by hand (about 50 kHz).
const RECOVERY_HALF_PERIOD_US: u16 = 10;

const TWINT: u8 = 1 << 7;
const TWSTA: u8 = 1 << 5;
const TWSTO: u8 = 1 << 4;
const TWEN: u8 = 1 << 2;
const TWIE: u8 = 1 << 0;

// TWSR status codes (prescaler bits masked).
const START: u8 = 0x08;
const REP_START: u8 = 0x10;
const MT_SLA_ACK: u8 = 0x18;
const MT_DATA_ACK: u8 = 0x28;
const ARB_LOST: u8 = 0x38;

/// Queued writes: 16 is a whole retry round for all four boards and more. A power of two.
const Q: u8 = 16;
const _: () = assert!(Q.is_power_of_two());
/// Board index (bits 0..=1) and register: bit 2 set for the configuration registers.
static mut Q_JOB: [u8; Q as usize] = [0; Q as usize];
static mut Q_VALUE: [u16; Q as usize] = [0; Q as usize];
/// Written by the main loop only.
static mut Q_HEAD: u8 = 0;
/// Written by the interrupt handler (and by [`check`] with interrupts off) only.
static mut Q_TAIL: u8 = 0;
/// Where the transaction at `Q_TAIL` is: 0 idle, 1 START sent, 2 address sent, 3..=5 the
/// register and the two data bytes sent.
static mut STEP: u8 = 0;
/// When the current step began (low 16 bits of the µs clock).
static mut STEP_AT: u16 = 0;
/// Failed attempts of the write at `Q_TAIL`.
static mut TRIES: u8 = 0;
/// Boards set aside after [`ATTEMPTS`] failures, one bit each.
static mut FAILED: u8 = 0;
/// Bus recoveries done so far.
static mut RECOVERIES: u16 = 0;

/// The register byte of a queued write.
pub const OUTPUTS: u8 = 0;
/// A queued write to the configuration registers (`[0x06, lo, hi]`).
pub const CONFIGURATION: u8 = 1 << 2;
/// A write addressed ahead whose outputs are not known yet: the handler holds the bus after
/// the register byte until [`push`] brings them.
const WAITING: u8 = 1 << 3;
/// A write addressed ahead that will bring no outputs: the handler ends it after the
/// register byte, with a STOP.
const ABORT: u8 = 1 << 4;
/// `STEP` while the bus is held after the register byte of a [`WAITING`] write.
const STEP_HELD: u8 = 0xFE;

/// The bus's 7-bit addresses, by board index (the thesis's 0x42..0x48 in write form).
pub const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];

fn twi() -> &'static avr_device::atmega16::twi::RegisterBlock {
    // SAFETY: the TWI is used only here: by the handler, and by the main loop while the
    // handler cannot run (interrupts off, or the TWI idle and its interrupt off).
    unsafe { &*TWI::ptr() }
}

fn portc() -> &'static avr_device::atmega16::portc::RegisterBlock {
    // SAFETY: PC0/PC1 belong to the TWI; only `recover` drives them, with interrupts off.
    unsafe { &*PORTC::ptr() }
}

#[inline(always)]
fn control(bits: u8) {
    twi().twcr.write(|w| unsafe { w.bits(bits) });
}

/// Sets the bit rate and enables the TWI. Takes the TWI and PORTC.
pub fn start(_twi: TWI, _portc: PORTC) {
    enable();
}

fn enable() {
    // Pins as inputs without pull-ups (the boards' bus has its own), until the TWI takes
    // them over.
    let p = portc();
    p.ddrc.modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
    p.portc.modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
    twi().twbr.write(|w| unsafe { w.bits(TWBR) });
    twi().twsr.write(|w| unsafe { w.bits(TWPS) });
    control(TWEN);
}

/// Board `b`'s bit (`b` 0..=3) in [`failed`]'s mask: `1 << b` is a loop of `b` shifts on
/// the AVR.
#[inline(always)]
pub fn board_bit(b: u8) -> u8 {
    const BITS: [u8; 4] = [1, 2, 4, 8];
    BITS[(b & 3) as usize]
}

/// Boards set aside after failing [`ATTEMPTS`] times (bit `i` = board `i`).
#[inline(always)]
pub fn failed() -> u8 {
    unsafe { read_volatile(addr_of!(FAILED)) }
}

/// Takes `board` back: its writes go out again.
pub fn clear_failed(board: u8) {
    avr_device::interrupt::free(|_| unsafe {
        write_volatile(addr_of_mut!(FAILED), failed() & !board_bit(board));
    });
}

/// Whether no write is queued or on the bus.
#[inline(always)]
pub fn idle() -> bool {
    unsafe {
        read_volatile(addr_of!(STEP)) == 0
            && read_volatile(addr_of!(Q_TAIL)) == read_volatile(addr_of!(Q_HEAD))
    }
}

/// Queues `[register, lo, hi]` for `board` (`kind` is [`OUTPUTS`] or [`CONFIGURATION`]) and
/// starts the bus if it is idle. Waits only if the queue is full (16 writes behind). The
/// outputs of the board addressed ahead go into its transaction (on at once if the bus is held
/// for them); any other write first ends that transaction.
pub fn push(board: u8, kind: u8, value: u16) {
    let filled = avr_device::interrupt::free(|_| unsafe {
        let Some(tail) = waiting() else {
            return false;
        };
        if kind != OUTPUTS || Q_JOB[tail] & 3 != board {
            abort();
            return false;
        }
        Q_VALUE[tail] = value;
        Q_JOB[tail] &= !WAITING;
        if STEP == STEP_HELD {
            // The register byte is out and the bus waits: the low byte now.
            twi().twdr.write(|w| w.bits(value as u8));
            STEP = 4;
            STEP_AT = clock::ticks16_raw();
            control(TWINT | TWEN | TWIE);
        }
        true
    });
    if filled {
        return;
    }
    enqueue(board | kind, value);
}

/// Puts a write at the queue's head and starts the bus if it is idle.
fn enqueue(job: u8, value: u16) {
    unsafe {
        let head = read_volatile(addr_of!(Q_HEAD));
        let next = (head + 1) % Q;
        while next == read_volatile(addr_of!(Q_TAIL)) {
            avr_device::asm::wdr();
            check();
        }
        write_volatile(addr_of_mut!(Q_JOB[head as usize]), job);
        write_volatile(addr_of_mut!(Q_VALUE[head as usize]), value);
        write_volatile(addr_of_mut!(Q_HEAD), next);
        if read_volatile(addr_of!(STEP)) == 0 {
            // Idle: the handler does not run until this START completes.
            avr_device::interrupt::free(|_| begin());
        }
    }
}

/// The write addressed ahead that still waits for its outputs: its queue index. It can only
/// be the write on the bus (it is queued when the bus is idle, and anything queued after it
/// ends it first).
#[inline(always)]
unsafe fn waiting() -> Option<usize> {
    let tail = (Q_TAIL & (Q - 1)) as usize;
    (Q_TAIL != read_volatile(addr_of!(Q_HEAD)) && Q_JOB[tail] & WAITING != 0).then_some(tail)
}

/// Addresses `board` ahead (the board the note message now waiting for its last byte would
/// write, or `None`): called by the main loop after every byte. Starts a transaction for it
/// when the bus is idle and it is not set aside; ends one waiting for another board, or for
/// none any more (the message is complete, and wrote nothing there, or was abandoned).
pub fn ahead(board: Option<u8>) {
    avr_device::interrupt::free(|_| unsafe {
        match (waiting(), board) {
            (Some(tail), Some(b)) if Q_JOB[tail] & 3 == b => {}
            (Some(_), _) => abort(),
            (None, Some(b)) if idle() && FAILED & board_bit(b) == 0 => {
                let head = Q_HEAD;
                Q_JOB[(head & (Q - 1)) as usize] = b | OUTPUTS | WAITING;
                Q_HEAD = (head + 1) % Q;
                begin();
            }
            _ => {}
        }
    });
}

/// Ends the transaction addressed ahead without data: at once with a STOP if the bus is held
/// for it (the next write's START right after), else the handler ends it after the register
/// byte. Interrupts off.
unsafe fn abort() {
    let tail = (Q_TAIL & (Q - 1)) as usize;
    Q_JOB[tail] = (Q_JOB[tail] & !WAITING) | ABORT;
    if STEP == STEP_HELD {
        done(twi());
    }
}

/// The write at `Q_TAIL` is done (or ended without data): a STOP, and the next write's START
/// right after it, unless its board is set aside or it was ended ahead (then the main loop's
/// [`begin`] skips it). Handler, or main loop with interrupts off.
#[inline(always)]
unsafe fn done(t: &avr_device::atmega16::twi::RegisterBlock) {
    let next = (Q_TAIL + 1) % Q;
    Q_TAIL = next;
    TRIES = 0;
    let job = Q_JOB[(next & (Q - 1)) as usize];
    if next != read_volatile(addr_of!(Q_HEAD)) && FAILED & board_bit(job) == 0 && job & ABORT == 0 {
        STEP = 1;
        STEP_AT = clock::ticks16_raw();
        t.twcr
            .write(|w| w.bits(TWINT | TWSTO | TWSTA | TWEN | TWIE));
    } else {
        STEP = 0;
        t.twcr.write(|w| w.bits(TWINT | TWSTO | TWEN));
    }
}

/// Starts the next queued write of a board that is not set aside, or stays idle. Called by
/// the main loop with interrupts off, while the handler is idle (or reported an error).
fn begin() {
    unsafe {
        let head = read_volatile(addr_of!(Q_HEAD));
        let mut tail = Q_TAIL;
        while tail != head
            && (FAILED & board_bit(Q_JOB[tail as usize]) != 0 || Q_JOB[tail as usize] & ABORT != 0)
        {
            tail = (tail + 1) % Q;
        }
        Q_TAIL = tail;
        TRIES = 0;
        STEP = 0;
        if tail != head {
            restart();
        }
    }
}

/// Sends a START for the write at `Q_TAIL`, once the last STOP is out. Main loop only.
fn restart() {
    stop_sent();
    unsafe {
        STEP = 1;
        STEP_AT = clock::ticks16_raw();
    }
    control(TWINT | TWSTA | TWEN | TWIE);
}

/// The write at `Q_TAIL` failed (NACK, lost arbitration, a bus error, or a timeout after a
/// recovery): try it again, or set its board aside and go on with the next write. Main loop
/// only, interrupts off.
fn fail() {
    unsafe {
        TRIES += 1;
        if Q_JOB[(Q_TAIL & (Q - 1)) as usize] & ABORT != 0 {
            // A write addressed ahead that was ended meanwhile: nothing to try again
            // (`begin` skips it).
            begin();
            return;
        }
        if TRIES < ATTEMPTS {
            restart();
            return;
        }
        FAILED |= board_bit(Q_JOB[Q_TAIL as usize]);
        // `begin` skips the board's queued writes.
        begin();
    }
}

/// `STEP` when the handler met a NACK, a lost arbitration or a bus error: it has let go of
/// the bus (a STOP where it may) and left the rest to [`check`].
const STEP_FAILED: u8 = 0xFF;

/// The TWI interrupt: only the steps of a write that goes well, and straight on to the next
/// queued write. It calls nothing (so it saves few registers); what goes wrong, and a next
/// write for a board set aside, are the main loop's, in [`check`].
#[avr_device::interrupt(atmega16)]
fn TWI() {
    crate::probe::twi_enter();
    let t = twi();
    let status = t.twsr.read().bits() & 0xF8;
    unsafe {
        let step = STEP;
        // Masked (Q is a power of two): no bounds check, so no call and few saved registers.
        let tail = (Q_TAIL & (Q - 1)) as usize;
        let ok = match step {
            1 => status == START || status == REP_START,
            2 => status == MT_SLA_ACK,
            _ => status == MT_DATA_ACK,
        };
        if !ok {
            // A lost arbitration has released the bus already; otherwise a STOP.
            t.twcr.write(|w| {
                w.bits(if status == ARB_LOST {
                    TWINT | TWEN
                } else {
                    TWINT | TWSTO | TWEN
                })
            });
            STEP = STEP_FAILED;
        } else if step == 3 && Q_JOB[tail] & (WAITING | ABORT) != 0 {
            // The register byte is out for a write addressed ahead.
            if Q_JOB[tail] & ABORT != 0 {
                // Nothing to write after all: a STOP.
                done(t);
            } else {
                // Its outputs are not known yet: hold the bus (TWINT stays set, SCL low) and
                // the interrupt off until `push` brings them.
                STEP = STEP_HELD;
                STEP_AT = clock::ticks16_raw();
                t.twcr.write(|w| w.bits(TWEN));
            }
        } else if step < 5 {
            let job = Q_JOB[tail];
            let byte = match step {
                1 => (ADDRESSES[0] + (job & 3)) << 1,
                2 => {
                    if job & CONFIGURATION != 0 {
                        CONFIGURATION_0
                    } else {
                        OUTPUT_PORT_0
                    }
                }
                3 => Q_VALUE[tail] as u8,
                _ => (Q_VALUE[tail] >> 8) as u8,
            };
            t.twdr.write(|w| w.bits(byte));
            STEP = step + 1;
            STEP_AT = clock::ticks16_raw();
            t.twcr.write(|w| w.bits(TWINT | TWEN | TWIE));
        } else {
            // Done, and straight on to the next write.
            done(t);
        }
    }
    crate::probe::twi_exit();
}

/// The main loop's part of the bus, called on every pass: retries and gives up after a
/// failed step, starts a write the handler left queued, and recovers the bus when a step
/// has taken longer than [`STEP_TIMEOUT_US`] (a bus held low, a dead TWI), counting a failed
/// attempt.
#[inline(always)]
pub fn check() {
    if idle() {
        return;
    }
    avr_device::interrupt::free(|_| unsafe {
        match STEP {
            0 => begin(),
            STEP_FAILED => fail(),
            // Held for outputs that did not come in time (the line stopped inside the message):
            // end it without data.
            STEP_HELD if clock::ticks16_raw().wrapping_sub(STEP_AT) > STEP_TIMEOUT_US => abort(),
            STEP_HELD => {}
            _ if clock::ticks16_raw().wrapping_sub(STEP_AT) > STEP_TIMEOUT_US => {
                recover();
                fail();
            }
            _ => {}
        }
    });
}

/// Lets go of every key at once, whatever the bus was doing: a panic's last act, with
/// interrupts off. The bus is freed by hand first ([`recover`]: it ends a transaction cut
/// short, a board still holding SDA is clocked free), then each board is written outputs 0 by
/// polling (a board that does not answer ignores the bytes after its address), each step
/// bounded by [`STEP_TIMEOUT_US`]: a dead bus costs at most ≈ 8 ms, and the watchdog's
/// reset (power-up releases every key) follows either way.
pub fn release_all_now() {
    recover();
    for board in 0..4u8 {
        let _ = step(TWINT | TWSTA | TWEN)
            && send((ADDRESSES[0] + board) << 1)
            && send(OUTPUT_PORT_0)
            && send(0)
            && send(0);
        // A STOP ends the write, or what of it went out.
        control(TWINT | TWSTO | TWEN);
        stop_sent();
    }
}

/// Waits until the last STOP is out (TWSTO clears), at most [`STEP_TIMEOUT_US`].
fn stop_sent() {
    let t0 = clock::ticks16_raw();
    while twi().twcr.read().bits() & TWSTO != 0
        && clock::ticks16_raw().wrapping_sub(t0) < STEP_TIMEOUT_US
    {}
}

/// One byte of a polled write.
fn send(byte: u8) -> bool {
    twi().twdr.write(|w| unsafe { w.bits(byte) });
    step(TWINT | TWEN)
}

/// One polled bus step (`bits` into TWCR, the TWI interrupt off): whether it ended within
/// [`STEP_TIMEOUT_US`].
#[inline(never)]
fn step(bits: u8) -> bool {
    control(bits);
    let t0 = clock::ticks16_raw();
    while twi().twcr.read().bits() & TWINT == 0 {
        if clock::ticks16_raw().wrapping_sub(t0) >= STEP_TIMEOUT_US {
            return false;
        }
    }
    true
}

/// Frees a stuck bus: TWI off, up to nine SCL pulses by hand until SDA is high, a STOP,
/// TWI back on. About 200 µs, with interrupts off.
#[inline(never)]
fn recover() {
    unsafe { RECOVERIES = RECOVERIES.wrapping_add(1) };
    control(0);
    // Open drain by hand: a line is released (input, pulled up outside) or driven low
    // (output, PORT bit 0).
    let p = portc();
    p.portc.modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
    p.ddrc.modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
    for _ in 0..9 {
        if p.pinc.read().bits() & 0b10 != 0 {
            break; // SDA is free
        }
        line(0b01, false);
        line(0b01, true);
    }
    // STOP: SDA low while SCL is high, then SDA released.
    line(0b10, false);
    line(0b01, true);
    line(0b10, true);
    enable();
}

fn line(mask: u8, high: bool) {
    portc().ddrc.modify(|r, w| unsafe {
        w.bits(if high {
            r.bits() & !mask
        } else {
            r.bits() | mask
        })
    });
    let t0 = clock::ticks16_raw();
    while clock::ticks16_raw().wrapping_sub(t0) < RECOVERY_HALF_PERIOD_US {}
}
