//! An embedded-hal 1.0 [`I2c`] master on the ATmega16's TWI, with timeouts instead of the
//! thesis's endless `while (!(TWCR & (1<<TWINT)));`, and bus recovery.
//!
//! Clock: 83.33 kHz as in the thesis (TWBR = 10, prescaler 4 at 8 MHz):
//! SCL = F_CPU / (16 + 2 · TWBR · 4^TWPS) = 8 MHz / 96.
//!
//! Every wait is bounded by Timer1 (1 µs ticks, see [`crate::clock`]). A wait that times out,
//! or a bus error (status 0x00), disables the TWI, clocks SCL up to nine times by hand until
//! a slave holding SDA lets go, sends a STOP and enables the TWI again. A NACK ends the
//! transaction with a STOP; arbitration loss releases the bus (the hardware already did).

use avr_device::atmega16::{PORTC, TWI};
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};

use crate::clock;

const TWINT: u8 = 1 << 7;
const TWEA: u8 = 1 << 6;
const TWSTA: u8 = 1 << 5;
const TWSTO: u8 = 1 << 4;
const TWEN: u8 = 1 << 2;

/// TWBR for 83.33 kHz at 8 MHz with prescaler 4 (the thesis's value).
pub const TWBR: u8 = 10;
/// TWPS = 1: prescaler 4.
pub const TWPS: u8 = 1;

/// The longest wait for one bus step (START, a byte and its ACK): a byte takes 108 µs at
/// 83.33 kHz, so 1 ms means the bus is stuck.
const STEP_TIMEOUT_US: u16 = 1000;
/// The longest wait for the STOP to go out.
const STOP_TIMEOUT_US: u16 = 300;
/// Half an SCL period while recovering the bus by hand (about 50 kHz).
const RECOVERY_HALF_PERIOD_US: u16 = 10;

// TWSR status codes (prescaler bits masked).
const START: u8 = 0x08;
const REP_START: u8 = 0x10;
const MT_SLA_ACK: u8 = 0x18;
const MT_SLA_NACK: u8 = 0x20;
const MT_DATA_ACK: u8 = 0x28;
const MT_DATA_NACK: u8 = 0x30;
const ARB_LOST: u8 = 0x38;
const MR_SLA_ACK: u8 = 0x40;
const MR_SLA_NACK: u8 = 0x48;
const MR_DATA_ACK: u8 = 0x50;
const MR_DATA_NACK: u8 = 0x58;

/// What went wrong on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TwiError {
    /// The address or a data byte was not acknowledged.
    Nack(NoAcknowledgeSource),
    /// Another master won the bus.
    ArbitrationLoss,
    /// A step did not finish in time (bus held low, or a dead TWI): the bus was recovered.
    Timeout,
    /// An illegal START/STOP or an unexpected status: the bus was recovered.
    Bus,
}

impl embedded_hal::i2c::Error for TwiError {
    fn kind(&self) -> ErrorKind {
        match *self {
            TwiError::Nack(s) => ErrorKind::NoAcknowledge(s),
            TwiError::ArbitrationLoss => ErrorKind::ArbitrationLoss,
            TwiError::Timeout | TwiError::Bus => ErrorKind::Bus,
        }
    }
}

/// The TWI master. Owns the TWI and PORTC (SCL = PC0, SDA = PC1).
pub struct Twi {
    twi: TWI,
    portc: PORTC,
    /// Bus recoveries done so far.
    pub recoveries: u16,
}

impl Twi {
    /// Sets the bit rate and enables the TWI.
    pub fn new(twi: TWI, portc: PORTC) -> Self {
        let mut this = Self {
            twi,
            portc,
            recoveries: 0,
        };
        this.enable();
        this
    }

    fn enable(&mut self) {
        // Pins as inputs without pull-ups (the boards' bus has its own), until the TWI
        // takes them over.
        self.portc
            .ddrc
            .modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
        self.portc
            .portc
            .modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
        self.twi.twbr.write(|w| unsafe { w.bits(TWBR) });
        self.twi.twsr.write(|w| unsafe { w.bits(TWPS) });
        self.twi.twcr.write(|w| unsafe { w.bits(TWEN) });
    }

    fn control(&mut self, bits: u8) {
        self.twi.twcr.write(|w| unsafe { w.bits(bits) });
    }

    /// Waits for TWINT, at most [`STEP_TIMEOUT_US`], and returns the status.
    fn wait(&mut self) -> Result<u8, TwiError> {
        let t0 = clock::ticks16();
        while self.twi.twcr.read().bits() & TWINT == 0 {
            if clock::ticks16().wrapping_sub(t0) > STEP_TIMEOUT_US {
                return Err(TwiError::Timeout);
            }
        }
        Ok(self.twi.twsr.read().bits() & 0xF8)
    }

    fn start(&mut self, repeated: bool) -> Result<(), TwiError> {
        self.control(TWINT | TWSTA | TWEN);
        match self.wait()? {
            START => Ok(()),
            REP_START if repeated => Ok(()),
            ARB_LOST => Err(TwiError::ArbitrationLoss),
            _ => Err(TwiError::Bus),
        }
    }

    fn send(&mut self, byte: u8) -> Result<u8, TwiError> {
        self.twi.twdr.write(|w| unsafe { w.bits(byte) });
        self.control(TWINT | TWEN);
        self.wait()
    }

    fn stop(&mut self) -> Result<(), TwiError> {
        self.control(TWINT | TWSTO | TWEN);
        let t0 = clock::ticks16();
        while self.twi.twcr.read().bits() & TWSTO != 0 {
            if clock::ticks16().wrapping_sub(t0) > STOP_TIMEOUT_US {
                return Err(TwiError::Timeout);
            }
        }
        Ok(())
    }

    fn address(&mut self, address: u8, read: bool) -> Result<(), TwiError> {
        let status = self.send((address << 1) | read as u8)?;
        match (status, read) {
            (MT_SLA_ACK, false) | (MR_SLA_ACK, true) => Ok(()),
            (MT_SLA_NACK, false) | (MR_SLA_NACK, true) => {
                Err(TwiError::Nack(NoAcknowledgeSource::Address))
            }
            (ARB_LOST, _) => Err(TwiError::ArbitrationLoss),
            _ => Err(TwiError::Bus),
        }
    }

    fn run(&mut self, address: u8, operations: &mut [Operation<'_>]) -> Result<(), TwiError> {
        let mut started: Option<bool> = None; // Some(read) once addressed
        let count = operations.len();
        for i in 0..count {
            let is_read = matches!(operations[i], Operation::Read(_));
            let next_is_read = i + 1 < count && matches!(operations[i + 1], Operation::Read(_));
            if started != Some(is_read) {
                self.start(started.is_some())?;
                self.address(address, is_read)?;
                started = Some(is_read);
            }
            match &mut operations[i] {
                Operation::Write(bytes) => {
                    for &b in bytes.iter() {
                        match self.send(b)? {
                            MT_DATA_ACK => {}
                            MT_DATA_NACK => return Err(TwiError::Nack(NoAcknowledgeSource::Data)),
                            ARB_LOST => return Err(TwiError::ArbitrationLoss),
                            _ => return Err(TwiError::Bus),
                        }
                    }
                }
                Operation::Read(buf) => {
                    let n = buf.len();
                    for (j, slot) in buf.iter_mut().enumerate() {
                        // NACK the last byte before a STOP or a repeated START.
                        let last = j + 1 == n && !next_is_read;
                        self.control(TWINT | TWEN | if last { 0 } else { TWEA });
                        match self.wait()? {
                            MR_DATA_ACK | MR_DATA_NACK => {}
                            ARB_LOST => return Err(TwiError::ArbitrationLoss),
                            _ => return Err(TwiError::Bus),
                        }
                        *slot = self.twi.twdr.read().bits();
                    }
                }
            }
        }
        if started.is_some() {
            self.stop()?;
        }
        Ok(())
    }

    /// Frees a stuck bus: TWI off, up to nine SCL pulses by hand until SDA is high, a STOP,
    /// TWI back on.
    pub fn recover(&mut self) {
        self.recoveries = self.recoveries.wrapping_add(1);
        self.twi.twcr.write(|w| unsafe { w.bits(0) });
        // Open drain by hand: a line is released (input, pulled up outside) or driven low
        // (output, PORT bit 0).
        self.portc
            .portc
            .modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
        self.portc
            .ddrc
            .modify(|r, w| unsafe { w.bits(r.bits() & !0b11) });
        for _ in 0..9 {
            if self.portc.pinc.read().bits() & 0b10 != 0 {
                break; // SDA is free
            }
            self.scl(false);
            self.scl(true);
        }
        // STOP: SDA low while SCL is high, then SDA released.
        self.sda(false);
        self.scl(true);
        self.sda(true);
        self.enable();
    }

    fn scl(&mut self, high: bool) {
        self.line(0b01, high);
    }

    fn sda(&mut self, high: bool) {
        self.line(0b10, high);
    }

    fn line(&mut self, mask: u8, high: bool) {
        self.portc.ddrc.modify(|r, w| unsafe {
            w.bits(if high {
                r.bits() & !mask
            } else {
                r.bits() | mask
            })
        });
        clock::delay_us(RECOVERY_HALF_PERIOD_US);
    }
}

impl ErrorType for Twi {
    type Error = TwiError;
}

impl I2c for Twi {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        let result = self.run(address, operations);
        match result {
            Ok(()) => Ok(()),
            Err(TwiError::Nack(s)) => {
                if self.stop().is_err() {
                    self.recover();
                }
                Err(TwiError::Nack(s))
            }
            // The hardware has released the bus already.
            Err(TwiError::ArbitrationLoss) => {
                self.control(TWINT | TWEN);
                Err(TwiError::ArbitrationLoss)
            }
            Err(e) => {
                self.recover();
                Err(e)
            }
        }
    }
}
