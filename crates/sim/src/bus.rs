//! A timed I2C bus with [`Pca9555`] and [`Pca9685`] models attached, implementing
//! [`embedded_hal::i2c::I2c`]. Both kinds may share one bus, each at its own address.
//!
//! **Cost of a transaction**, in bit-times of the [`BusClock`]:
//! 1 for START, 9 for every byte on the wire (8 bits and the ACK/NACK bit; the address byte
//! counts), 1 for every repeated START, 1 for STOP. Following the embedded-hal transaction
//! contract, adjacent operations of the same kind are one frame (no repeated START, no new
//! address byte between them); a repeated START and address byte separate a write from a read.
//! A write of `[0x02, lo, hi]` is 1 + 4 × 9 + 1 = 38 bit-times: 456 µs at 83.33 kHz.
//!
//! **Time.** The caller sets the present with [`VirtualBus::set_time`]. A transaction starts at
//! the later of the present and the moment the bus becomes free (transactions never overlap),
//! and completes after its bit-times. The devices' registers change at completion: that is
//! the time stamped on pin changes and in the write log. Clock stretching and arbitration are
//! not modelled.
//!
//! **Changes.** A PCA9555's driven pins that a transaction changed come out as a [`PinChange`]
//! ([`VirtualBus::take_pin_changes`]); a PCA9685's channel duties that a transaction changed
//! as a [`DutyChange`] ([`VirtualBus::take_duty_changes`]), both stamped with the
//! transaction's completion.
//!
//! **Errors.** An address with no device is not acknowledged: the transaction costs START,
//! the address byte and STOP, and fails with [`ErrorKind::NoAcknowledge`]`(`[`NoAcknowledgeSource::Address`]`)`.

use core::fmt;

use embedded_hal::i2c::{
    self, ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation, SevenBitAddress,
};
use orch_core::{Duration, Instant};
use serde::Serialize;

use crate::pca9555::Pca9555;
use crate::pca9685::Pca9685;

/// A point in simulated time, in nanoseconds since the origin (the origin of
/// [`orch_core::Instant`]). Nanoseconds, because bit-times at 400 kHz are 2.5 µs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize)]
#[serde(transparent)]
pub struct SimTime(u64);

impl SimTime {
    /// The origin.
    pub const ZERO: Self = Self(0);

    /// `nanos` nanoseconds after the origin.
    pub const fn from_nanos(nanos: u64) -> Self {
        Self(nanos)
    }

    /// `micros` microseconds after the origin.
    pub const fn from_micros(micros: u64) -> Self {
        Self(micros.saturating_mul(1_000))
    }

    /// `millis` milliseconds after the origin.
    pub const fn from_millis(millis: u64) -> Self {
        Self(millis.saturating_mul(1_000_000))
    }

    /// Nanoseconds since the origin.
    pub const fn as_nanos(self) -> u64 {
        self.0
    }

    /// Whole microseconds since the origin (rounded down).
    pub const fn as_micros(self) -> u64 {
        self.0 / 1_000
    }

    /// `self` plus `nanos` nanoseconds, saturating.
    pub const fn plus_nanos(self, nanos: u64) -> Self {
        Self(self.0.saturating_add(nanos))
    }

    /// `self` plus an [`orch_core::Duration`] (microseconds), saturating.
    pub const fn after(self, d: Duration) -> Self {
        self.plus_nanos(d.as_micros() as u64 * 1_000)
    }

    /// Nanoseconds from `earlier` to `self`, or 0 if `earlier` is later.
    pub const fn nanos_since(self, earlier: SimTime) -> u64 {
        self.0.saturating_sub(earlier.0)
    }
}

impl From<Instant> for SimTime {
    fn from(t: Instant) -> Self {
        Self::from_micros(t.as_micros())
    }
}

impl core::ops::Add<Duration> for SimTime {
    type Output = SimTime;
    fn add(self, rhs: Duration) -> SimTime {
        self.after(rhs)
    }
}

impl fmt::Display for SimTime {
    /// Microseconds with three decimals: `456.000us`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:03}us", self.0 / 1_000, self.0 % 1_000)
    }
}

/// The bus clock (SCL frequency), kept as an exact fraction `numerator / denominator` Hz.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BusClock {
    numerator: u64,
    denominator: u64,
}

impl BusClock {
    /// The thesis's clock: an ATmega16 at 8 MHz with TWBR = 10 and prescaler 4,
    /// 8 MHz / (16 + 2 × 10 × 4) = 83 333.3 Hz, one bit every 12 µs.
    pub const THESIS: Self = Self::from_avr_twi(8_000_000, 10, 4);
    /// Standard mode, 100 kHz (10 µs a bit).
    pub const STANDARD: Self = Self::from_hz(100_000);
    /// Fast mode, 400 kHz (2.5 µs a bit).
    pub const FAST: Self = Self::from_hz(400_000);

    /// A clock of `hz` Hz. `hz` must not be 0.
    pub const fn from_hz(hz: u32) -> Self {
        assert!(hz > 0, "a bus clock of 0 Hz");
        Self {
            numerator: hz as u64,
            denominator: 1,
        }
    }

    /// The clock of an AVR TWI master: `f_cpu / (16 + 2 × twbr × prescaler)`.
    pub const fn from_avr_twi(f_cpu: u32, twbr: u8, prescaler: u8) -> Self {
        assert!(f_cpu > 0, "a CPU clock of 0 Hz");
        Self {
            numerator: f_cpu as u64,
            denominator: 16 + 2 * twbr as u64 * prescaler as u64,
        }
    }

    /// The frequency in Hz.
    pub fn hz(self) -> f64 {
        self.numerator as f64 / self.denominator as f64
    }

    /// How long `bits` bit-times take, in nanoseconds, rounded up to a whole nanosecond.
    pub const fn nanos_for_bits(self, bits: u64) -> u64 {
        let num = bits as u128 * 1_000_000_000 * self.denominator as u128;
        let den = self.numerator as u128;
        num.div_ceil(den) as u64
    }
}

impl Default for BusClock {
    fn default() -> Self {
        Self::THESIS
    }
}

/// What went wrong on a [`VirtualBus`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BusError {
    /// No device acknowledged this address.
    AddressNack {
        /// The 7-bit address.
        address: u8,
    },
    /// Not a 7-bit address (above 0x7F); nothing was sent.
    InvalidAddress {
        /// The address asked for.
        address: u8,
    },
}

impl i2c::Error for BusError {
    fn kind(&self) -> ErrorKind {
        match self {
            BusError::AddressNack { .. } => ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address),
            BusError::InvalidAddress { .. } => ErrorKind::Other,
        }
    }
}

impl fmt::Display for BusError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BusError::AddressNack { address } => {
                write!(f, "no device acknowledged I2C address {address:#04x}")
            }
            BusError::InvalidAddress { address } => {
                write!(f, "{address:#04x} is not a 7-bit I2C address")
            }
        }
    }
}

impl std::error::Error for BusError {}

/// One completed (acknowledged) write frame, as the bus log keeps it.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct BusWrite {
    /// When its transaction started (START).
    pub start: SimTime,
    /// When its transaction completed (STOP); the registers changed then.
    pub end: SimTime,
    /// The 7-bit device address.
    pub address: u8,
    /// The bytes after the address byte: command byte, then data.
    pub bytes: Vec<u8>,
    /// The device's driven pins after the transaction ([`Pca9555::driven`]; for a PCA9685,
    /// the channels high some of the time, [`Pca9685::driven`]).
    pub driven: u16,
    /// For a PCA9685, every channel's duty after the transaction ([`Pca9685::duties`],
    /// 0..=4095, 4095 = 100 %); `None` for a PCA9555 (and then not serialised).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duty: Option<[u16; 16]>,
}

/// A change of a device's driven pins, at the completion of the transaction that caused it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PinChange {
    /// When the transaction completed.
    pub time: SimTime,
    /// The device's 7-bit address.
    pub address: u8,
    /// Driven pins before.
    pub before: u16,
    /// Driven pins after.
    pub after: u16,
}

/// A change of a PCA9685's channel duties ([`Pca9685::duties`]), at the completion of the
/// transaction that caused it. The chip applies it at its next PWM period, up to
/// [`Pca9685::period_nanos`] later.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DutyChange {
    /// When the transaction completed.
    pub time: SimTime,
    /// The device's 7-bit address.
    pub address: u8,
    /// Every channel's duty before.
    pub before: [u16; 16],
    /// Every channel's duty after.
    pub after: [u16; 16],
}

/// A device to attach to a [`VirtualBus`]: either board kind.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Chip {
    /// An on/off board.
    Pca9555(Pca9555),
    /// A PWM board.
    Pca9685(Pca9685),
}

impl From<Pca9555> for Chip {
    fn from(chip: Pca9555) -> Self {
        Chip::Pca9555(chip)
    }
}

impl From<Pca9685> for Chip {
    fn from(chip: Pca9685) -> Self {
        Chip::Pca9685(chip)
    }
}

/// Where an attached device is kept: its kind's list and its index there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    Io(usize),
    Pwm(usize),
}

/// What a device drives, before and after a transaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Output {
    Pins(u16),
    Duties([u16; 16]),
}

/// Bus counters since creation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct BusStats {
    /// Transactions sent (acknowledged or not).
    pub transactions: u64,
    /// Transactions whose address byte was not acknowledged.
    pub nacks: u64,
    /// Bytes on the wire, address bytes included.
    pub bytes: u64,
    /// Bit-times on the wire: START, 9 a byte, repeated STARTs and STOP.
    pub bit_times: u64,
    /// Nanoseconds the bus was busy.
    pub busy_nanos: u64,
}

/// An I2C bus with devices on it, keeping time. See the [module notes](self).
#[derive(Clone, Debug)]
pub struct VirtualBus {
    clock: BusClock,
    devices: Vec<Pca9555>,
    pwm: Vec<Pca9685>,
    /// Every device by address, in attachment order.
    slots: Vec<(u8, Slot)>,
    now: SimTime,
    free_at: SimTime,
    stats: BusStats,
    log: Vec<BusWrite>,
    keep_log: bool,
    changes: Vec<PinChange>,
    duty_changes: Vec<DutyChange>,
    last: Option<(SimTime, SimTime)>,
}

impl VirtualBus {
    /// An empty bus at `clock`, at time zero.
    pub fn new(clock: BusClock) -> Self {
        Self {
            clock,
            devices: Vec::new(),
            pwm: Vec::new(),
            slots: Vec::new(),
            now: SimTime::ZERO,
            free_at: SimTime::ZERO,
            stats: BusStats::default(),
            log: Vec::new(),
            keep_log: true,
            changes: Vec::new(),
            duty_changes: Vec::new(),
            last: None,
        }
    }

    /// Attaches a device, a [`Pca9555`] or a [`Pca9685`]. Give each device its own address: if
    /// two share one, only the first attached answers (a real bus would have both drive at
    /// once).
    pub fn attach(&mut self, device: impl Into<Chip>) {
        match device.into() {
            Chip::Pca9555(d) => {
                self.slots.push((d.address(), Slot::Io(self.devices.len())));
                self.devices.push(d);
            }
            Chip::Pca9685(d) => {
                self.slots.push((d.address(), Slot::Pwm(self.pwm.len())));
                self.pwm.push(d);
            }
        }
    }

    /// The device that answers `address`, if any.
    fn slot(&self, address: u8) -> Option<Slot> {
        self.slots
            .iter()
            .find(|(a, _)| *a == address)
            .map(|&(_, s)| s)
    }

    /// The bus clock.
    pub fn clock(&self) -> BusClock {
        self.clock
    }

    /// Sets the present: the next transaction starts no earlier than `t`. Setting an earlier
    /// time than before is allowed and harmless (transactions still never overlap).
    pub fn set_time(&mut self, t: impl Into<SimTime>) {
        self.now = t.into();
    }

    /// The present, as last set.
    pub fn now(&self) -> SimTime {
        self.now
    }

    /// When the last transaction completes (the bus is free from then on).
    pub fn free_at(&self) -> SimTime {
        self.free_at
    }

    /// Start and end of the last transaction, if any.
    pub fn last_transaction(&self) -> Option<(SimTime, SimTime)> {
        self.last
    }

    /// The PCA9555 that answers `address`, if any.
    pub fn device(&self, address: u8) -> Option<&Pca9555> {
        match self.slot(address)? {
            Slot::Io(i) => self.devices.get(i),
            Slot::Pwm(_) => None,
        }
    }

    /// The PCA9555 that answers `address`, mutably (to reset it, say), if any.
    pub fn device_mut(&mut self, address: u8) -> Option<&mut Pca9555> {
        match self.slot(address)? {
            Slot::Io(i) => self.devices.get_mut(i),
            Slot::Pwm(_) => None,
        }
    }

    /// Every PCA9555, in attachment order.
    pub fn devices(&self) -> &[Pca9555] {
        &self.devices
    }

    /// The PCA9685 that answers `address`, if any.
    pub fn pca9685(&self, address: u8) -> Option<&Pca9685> {
        match self.slot(address)? {
            Slot::Pwm(i) => self.pwm.get(i),
            Slot::Io(_) => None,
        }
    }

    /// The PCA9685 that answers `address`, mutably (to reset it or drive its `OE` pin), if
    /// any. A change made here is not a transaction: it reaches no [`DutyChange`].
    pub fn pca9685_mut(&mut self, address: u8) -> Option<&mut Pca9685> {
        match self.slot(address)? {
            Slot::Pwm(i) => self.pwm.get_mut(i),
            Slot::Io(_) => None,
        }
    }

    /// Every PCA9685, in attachment order.
    pub fn pca9685s(&self) -> &[Pca9685] {
        &self.pwm
    }

    /// The counters.
    pub fn stats(&self) -> BusStats {
        self.stats
    }

    /// Every acknowledged write frame, oldest first.
    pub fn log(&self) -> &[BusWrite] {
        &self.log
    }

    /// Forgets the write log (the counters stay): for long runs that keep only figures.
    pub fn clear_log(&mut self) {
        self.log.clear();
    }

    /// Whether to keep the write log (on by default; off, only the counters are kept).
    pub fn keep_log(&mut self, keep: bool) {
        self.keep_log = keep;
    }

    /// Hands the pin changes since the last call to `f`, oldest first, and forgets them.
    pub fn drain_pin_changes(&mut self, f: impl FnMut(PinChange)) {
        self.changes.drain(..).for_each(f);
    }

    /// Takes the driven-pin changes recorded since the last call, oldest first. Their times
    /// never decrease.
    pub fn take_pin_changes(&mut self) -> Vec<PinChange> {
        core::mem::take(&mut self.changes)
    }

    /// Hands the PCA9685 duty changes since the last call to `f`, oldest first, and forgets
    /// them.
    pub fn drain_duty_changes(&mut self, f: impl FnMut(DutyChange)) {
        self.duty_changes.drain(..).for_each(f);
    }

    /// Takes the PCA9685 duty changes recorded since the last call, oldest first. Their times
    /// never decrease.
    pub fn take_duty_changes(&mut self) -> Vec<DutyChange> {
        core::mem::take(&mut self.duty_changes)
    }

    /// Bit-times of a transaction made of `frames` (lengths in data bytes, alternating kinds as
    /// the embedded-hal contract groups them): START, an address byte and the data of each
    /// frame, a repeated START between frames, STOP.
    pub fn bits_for_frames(frames: &[usize]) -> u64 {
        let bytes: u64 = frames.iter().map(|&n| 1 + n as u64).sum();
        let repeated_starts = frames.len().saturating_sub(1) as u64;
        1 + 9 * bytes + repeated_starts + 1
    }

    /// Occupies the bus for `bits` bit-times from `max(now, free_at)`; returns (start, end).
    fn occupy(&mut self, bits: u64, bytes: u64) -> (SimTime, SimTime) {
        let start = self.now.max(self.free_at);
        let nanos = self.clock.nanos_for_bits(bits);
        let end = start.plus_nanos(nanos);
        self.free_at = end;
        self.last = Some((start, end));
        self.stats.transactions += 1;
        self.stats.bytes += bytes;
        self.stats.bit_times += bits;
        self.stats.busy_nanos += nanos;
        (start, end)
    }
}

impl Default for VirtualBus {
    /// An empty bus at the thesis's clock.
    fn default() -> Self {
        Self::new(BusClock::THESIS)
    }
}

impl ErrorType for VirtualBus {
    type Error = BusError;
}

impl VirtualBus {
    /// What the device in `slot` drives now.
    fn output(&self, slot: Slot) -> Output {
        match slot {
            Slot::Io(i) => Output::Pins(self.devices[i].driven()),
            Slot::Pwm(i) => Output::Duties(self.pwm[i].duties()),
        }
    }

    fn write_frame(&mut self, slot: Slot, data: &[u8]) {
        match slot {
            Slot::Io(i) => self.devices[i].write_frame(data),
            Slot::Pwm(i) => self.pwm[i].write_frame(data),
        }
    }

    fn read_frame(&self, slot: Slot, data: &mut [u8]) {
        match slot {
            Slot::Io(i) => self.devices[i].read_frame(data),
            Slot::Pwm(i) => self.pwm[i].read_frame(data),
        }
    }

    /// After a transaction with the device at `address` over `span`: logs its write frames
    /// (if the log is kept) and the pin or duty change, if its outputs changed from `before`.
    fn record(
        &mut self,
        (address, slot): (u8, Slot),
        (start, end): (SimTime, SimTime),
        before: Output,
        writes: impl IntoIterator<Item = Vec<u8>>,
    ) {
        let after = self.output(slot);
        let (driven, duty) = match slot {
            Slot::Io(i) => (self.devices[i].driven(), None),
            Slot::Pwm(i) => (self.pwm[i].driven(), Some(self.pwm[i].duties())),
        };
        if self.keep_log {
            for bytes in writes {
                self.log.push(BusWrite {
                    start,
                    end,
                    address,
                    bytes,
                    driven,
                    duty,
                });
            }
        }
        match (before, after) {
            (Output::Pins(before), Output::Pins(after)) if before != after => {
                self.changes.push(PinChange {
                    time: end,
                    address,
                    before,
                    after,
                });
            }
            (Output::Duties(before), Output::Duties(after)) if before != after => {
                self.duty_changes.push(DutyChange {
                    time: end,
                    address,
                    before,
                    after,
                });
            }
            _ => {}
        }
    }
}

/// A run of adjacent operations of one kind: one frame on the wire.
fn frames(operations: &[Operation<'_>]) -> Vec<(bool, core::ops::Range<usize>)> {
    let mut out: Vec<(bool, core::ops::Range<usize>)> = Vec::new();
    for (i, op) in operations.iter().enumerate() {
        let is_read = matches!(op, Operation::Read(_));
        match out.last_mut() {
            Some((kind, range)) if *kind == is_read => range.end = i + 1,
            _ => out.push((is_read, i..i + 1)),
        }
    }
    out
}

fn op_len(op: &Operation<'_>) -> usize {
    match op {
        Operation::Read(b) => b.len(),
        Operation::Write(b) => b.len(),
    }
}

impl I2c<SevenBitAddress> for VirtualBus {
    fn transaction(
        &mut self,
        address: SevenBitAddress,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        if address > 0x7F {
            return Err(BusError::InvalidAddress { address });
        }
        if operations.is_empty() {
            return Ok(()); // nothing goes on the wire
        }
        let Some(slot) = self.slot(address) else {
            // START, the address byte (NACKed), STOP.
            self.occupy(1 + 9 + 1, 1);
            self.stats.nacks += 1;
            return Err(BusError::AddressNack { address });
        };

        if let [Operation::Write(data)] = operations {
            // The common case, a driver's single write: no allocation unless it is logged.
            let data: &[u8] = data;
            let (start, end) =
                self.occupy(Self::bits_for_frames(&[data.len()]), 1 + data.len() as u64);
            let before = self.output(slot);
            self.write_frame(slot, data);
            // The bytes are copied only when the log keeps them.
            let logged = self.keep_log.then(|| data.to_vec());
            self.record((address, slot), (start, end), before, logged);
            return Ok(());
        }
        let groups = frames(operations);
        let lengths: Vec<usize> = groups
            .iter()
            .map(|(_, r)| operations[r.clone()].iter().map(op_len).sum())
            .collect();
        let bits = Self::bits_for_frames(&lengths);
        let bytes = lengths.iter().map(|&n| 1 + n as u64).sum();
        let (start, end) = self.occupy(bits, bytes);

        let before = self.output(slot);
        let mut writes = Vec::new();
        for (is_read, range) in groups {
            if is_read {
                // One frame across adjacent reads: the pair toggles on from buffer to buffer.
                let total: usize = operations[range.clone()].iter().map(op_len).sum();
                let mut data = vec![0; total];
                self.read_frame(slot, &mut data);
                let mut at = 0;
                for op in &mut operations[range] {
                    if let Operation::Read(buf) = op {
                        buf.copy_from_slice(&data[at..at + buf.len()]);
                        at += buf.len();
                    }
                }
            } else {
                let mut data = Vec::new();
                for op in &operations[range] {
                    if let Operation::Write(b) = op {
                        data.extend_from_slice(b);
                    }
                }
                self.write_frame(slot, &data);
                writes.push(data);
            }
        }
        self.record((address, slot), (start, end), before, writes);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_clock_is_12_us_a_bit() {
        assert_eq!(BusClock::THESIS.nanos_for_bits(1), 12_000);
        assert!((BusClock::THESIS.hz() - 83_333.333).abs() < 0.001);
        assert_eq!(BusClock::FAST.nanos_for_bits(1), 2_500);
    }

    #[test]
    fn frame_bits_follow_the_formula() {
        assert_eq!(VirtualBus::bits_for_frames(&[3]), 38);
        assert_eq!(VirtualBus::bits_for_frames(&[0]), 11);
        // write_read([cmd], [2 bytes]): START, addr+cmd, Sr, addr+2, STOP.
        assert_eq!(VirtualBus::bits_for_frames(&[1, 2]), 1 + 18 + 1 + 27 + 1);
    }

    #[test]
    fn of_two_boards_at_one_address_the_first_attached_answers() {
        let mut bus = VirtualBus::default();
        bus.attach(Pca9685::new(0x21));
        bus.attach(Pca9555::new(0x21));
        bus.write(0x21, &[0x00, 0x20]).unwrap(); // MODE1 of the PCA9685: awake
        assert!(!bus.pca9685(0x21).unwrap().sleeping());
        assert!(bus.device(0x21).is_none(), "the PCA9555 never answers");
        assert_eq!(bus.devices()[0].configuration(), 0xFFFF);
    }

    #[test]
    fn adjacent_writes_are_one_frame() {
        let mut bus = VirtualBus::default();
        bus.attach(Pca9555::new(0x21));
        bus.transaction(
            0x21,
            &mut [Operation::Write(&[0x06]), Operation::Write(&[0x00, 0x00])],
        )
        .unwrap();
        assert_eq!(bus.stats().bit_times, 38);
        assert_eq!(bus.device(0x21).unwrap().configuration(), 0);
        assert_eq!(bus.log()[0].bytes, vec![0x06, 0x00, 0x00]);
    }
}
