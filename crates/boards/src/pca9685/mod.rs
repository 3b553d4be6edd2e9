//! The NXP PCA9685: 16 channels of 12-bit PWM on I2C (to 1 MHz), for keys whose solenoids
//! strike at one duty and hold at a lower one.
//!
//! - [`Pca9685`] drives one chip on a blocking embedded-hal 1.0 bus; `asynch::Pca9685Async`
//!   (feature `async`) is the same driver on embedded-hal-async, byte for byte.
//! - [`Pca9685Set`] owns one blocking bus and `N` chips (a robot's PWM boards), each with its
//!   own cache, writing the same bytes.
//! - [`registers`] holds the data sheet's register map and bits, [`Prescale`] the PWM
//!   frequency.
//!
//! # Duty
//!
//! A duty is 0..=[`MAX_DUTY`] (4095) per channel, in 1/4096 of the PWM period, except the top:
//!
//! | duty | registers | output high for |
//! |---|---|---|
//! | 0 | full OFF (`LEDn_OFF_H` bit 4) | never |
//! | 1..=4094 | ON = `256 × n` (channel `n`'s phase), OFF = `(ON + duty) mod 4096` | `duty / 4096` of the period |
//! | 4095 ([`FULL_ON`]) | full ON (`LEDn_ON_H` bit 4) | always (100 %) |
//!
//! So the 4096 steps run 0, 1/4096, …, 4094/4096, then 100 %: the one step from 4094 to
//! 4095 is 2/4096, and 4095/4096 is not made. 0 and 100 % use the full OFF / full ON bits
//! because no ON/OFF count pair makes them (the data sheet forbids ON = OFF).
//!
//! Each channel goes high at its own phase, `256 × n` counts into the period: sixteen coils
//! switched on at the same instant draw sixteen inrush edges at once from the supply; spread
//! over the period they draw one at a time (the data sheet's own example delays the ON
//! count this way). An OFF count below the ON count wraps past the period's end, as the data
//! sheet allows.
//!
//! # What goes on the wire
//!
//! - **[`init`](Pca9685::init)**, five writes, then a wait:
//!   1. `[ALL_LED_OFF_H, 0x10]`: every channel fully off, in a 2-byte write that works while
//!      auto-increment is still off (as it is at power-up);
//!   2. `[MODE1, SLEEP | AI]`: oscillator off (`PRE_SCALE` is writable only asleep);
//!   3. `[PRE_SCALE, p]`;
//!   4. `[MODE2, OUTDRV]`: totem-pole outputs, not inverted (the data sheet's table 11 calls
//!      this the optimum for an external N-type driver, a low-side MOSFET: no pull-up needed),
//!      outputs change at the STOP (every channel of one write changes at once), outputs 0
//!      while the `OE` pin is high (`OE` is the hardware stop);
//!   5. `[MODE1, AI]`: awake, auto-increment on, no sub or all-call addresses (each board
//!      answers its own address only);
//!   6. a wait of 500 µs ([`registers::OSCILLATOR_STARTUP_US`]) on the caller's `DelayNs`: the
//!      oscillator's start-up, before any channel may be written.
//!
//!   **Restart** (data sheet 7.3.1.1): `RESTART` is set only when channels were running as the
//!   chip went to sleep; step 1 turns them all off first (an "orderly shutdown"), which clears
//!   it, so init never restarts anything: after it every channel is fully off, awake, and the
//!   cache knows it.
//! - **A key change**: one write `[LEDn_ON_L, on_l, on_h, off_l, off_h]`, 5 bytes with the
//!   register ([`set_duty`](Pca9685::set_duty)): 1 + 6 × 9 + 1 = 56 bit-times, 140 µs at
//!   400 kHz, 56 µs at 1 MHz (a PCA9555 change is 38 bit-times).
//! - **Several channels**: [`set_duties`](Pca9685::set_duties) writes the run from the first to
//!   the last changed channel in one auto-increment write (all 16: 65 bytes, 596 bit-times),
//!   so a chord's keys change at the same STOP.
//! - **Stop**: [`all_off`](Pca9685::all_off) is `[ALL_LED_OFF_H, 0x10]`, one 2-byte write for
//!   the whole board.
//! - **Sleep** and **restart**: [`sleep`](Pca9685::sleep) writes `[MODE1, SLEEP | AI]` (every
//!   output off, registers kept); [`restart`](Pca9685::restart) reads `MODE1`, writes `[MODE1,
//!   AI]`, waits 500 µs, and, if `RESTART` read 1, writes `[MODE1, RESTART | AI]`, which
//!   restarts the held channels (data sheet 7.3.1.1, steps 1–3).
//! - **Nothing changed**: nothing is written. The driver caches each channel's duty as last
//!   written successfully; a failed write forgets the channels it was writing (all of them for
//!   `init` and `all_off`), so the next write to them goes out.
//!
//! # Power-up
//!
//! The chip powers up asleep (`MODE1` = 0x11) with every `LEDn_OFF_H` = 0x10, full OFF: nothing
//! is driven. Nothing this driver writes can energise a channel before that channel's duty is
//! set: `init` writes full OFF everywhere before anything else, and the other steps touch only
//! the mode and prescale registers. If `init` fails part-way the channels are still off (and the
//! chip may be asleep); call it again.
//!
//! One case it cannot cover: a chip that other software left running with `MODE2`'s `INVRT`
//! set outputs the inverse of full OFF, high, from step 1 until step 4 clears `INVRT` at the
//! latest (three 29-bit writes: about 0.2 ms at 400 kHz). At power-up `MODE2` is 0x04 and this driver never sets `INVRT`; the
//! `OE` pin held high over a re-initialisation covers even that case.
//!
//! # PWM frequency: the default is the highest, 1526 Hz
//!
//! The chip makes `25 MHz / (4096 × (PRE_SCALE + 1))` with `PRE_SCALE` 3..=255: 1525.9 Hz down to
//! 23.8 Hz; ultrasonic (above 20 kHz) is out of its reach. [`DEFAULT_FREQUENCY_HZ`] is 1526 Hz
//! (`PRE_SCALE` = 3), the top, for three reasons and at one cost:
//!
//! - **No click.** bbswitzer's piano held its keys at 100 % because a lower hold clicked at
//!   75 Hz software PWM. A coil's current follows the PWM when the period is long against the
//!   coil's `L/R` (an estimate for a small 24 V, 750 mA solenoid: 32 Ω, some 20 mH, 0.6 ms):
//!   at 75 Hz (13 ms) it swings fully on and off every period and the plunger buzzes; at
//!   1526 Hz (0.66 ms) it ripples around its mean, and what is left is 20× higher in frequency,
//!   where a plunger and key's mass follows it about 400× less (displacement goes as
//!   force / ω²).
//! - **Latency.** The chip applies a new ON/OFF count at the end of the output's LOW time
//!   (data sheet 7.3.4, against glitches), so a key change waits up to one period after its
//!   STOP: 0.66 ms at 1526 Hz, 5 ms at the power-up 200 Hz, 13 ms at 75 Hz.
//! - **No loss of resolution.** Every frequency has the same 4096 counts.
//! - **The cost, switching losses, stays small in this range.** The outputs source 10 mA, so a
//!   logic-level MOSFET with 10 nC of gate charge switches in about 1 µs; at 24 V and 0.75 A
//!   that is about 9 µJ an edge, two edges a period: about 27 mW a channel at 1526 Hz, the
//!   same order as its conduction loss (0.75² A² × 50 mΩ = 28 mW), far from heating a TO-220
//!   or the chip. (At 20 kHz it would be 360 mW: that is where "too high heats the driver"
//!   starts; this chip cannot go there.) A MOSFET with a much larger gate charge should get a
//!   gate driver rather than a lower frequency.
//!
//! Peers use 1–1.5 kHz. If a coil sings audibly at 1.5 kHz, a lower frequency is a setting:
//! [`Prescale::from_hz`] refuses one the chip cannot make (24..=1526 Hz).

pub(crate) mod device;
pub(crate) mod frames;
pub mod registers;
mod set;

pub use device::Pca9685;
pub use set::Pca9685Set;

use registers::{COUNTS, OSCILLATOR_HZ, PRE_SCALE_MAX, PRE_SCALE_MIN};

/// Channels on a chip.
pub const CHANNELS: usize = 16;
/// The largest duty: 100 %, the full-ON bit.
pub const MAX_DUTY: u16 = 4095;
/// The duty written as full ON (100 %); see the [module notes](self#duty).
pub const FULL_ON: u16 = MAX_DUTY;
/// Counts between the ON edges of neighbouring channels: channel `n` goes high at `256 × n`.
pub const PHASE_STEP: u16 = 256;
/// The default PWM frequency: the highest the chip makes (`PRE_SCALE` 3, 1525.9 Hz). Why: the
/// [module notes](self#pwm-frequency-the-default-is-the-highest-1526-hz).
pub const DEFAULT_FREQUENCY_HZ: u32 = 1526;
/// The lowest frequency asked for that [`Prescale::from_hz`] accepts.
pub const MIN_FREQUENCY_HZ: u32 = 24;
/// The highest frequency asked for that [`Prescale::from_hz`] accepts.
pub const MAX_FREQUENCY_HZ: u32 = 1526;
/// The 7-bit address with A5..A0 all low; a chip answers `0x40 | A5..A0` (0x40..=0x7F, but 0x70
/// is the power-up All Call address: avoid it).
pub const BASE_ADDRESS: u8 = 0x40;

/// A `PRE_SCALE` value, 3..=255, and so a PWM frequency of `25 MHz / (4096 × (value + 1))`
/// with the internal oscillator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Prescale(u8);

impl Prescale {
    /// The default ([`DEFAULT_FREQUENCY_HZ`]): 3.
    pub const DEFAULT: Self = Self(PRE_SCALE_MIN);

    /// The prescale for `hz`, as the data sheet computes it:
    /// `round(25 MHz / (4096 × hz)) − 1`. `None` unless `hz` is in
    /// [`MIN_FREQUENCY_HZ`]`..=`[`MAX_FREQUENCY_HZ`] (24..=1526 Hz): outside, the value would
    /// fall outside 3..=255 (or round to 3 while the chip makes less than asked).
    pub const fn from_hz(hz: u32) -> Option<Self> {
        if hz < MIN_FREQUENCY_HZ || hz > MAX_FREQUENCY_HZ {
            return None;
        }
        let den = COUNTS as u64 * hz as u64;
        let rounded = (OSCILLATOR_HZ as u64 + den / 2) / den;
        let value = rounded - 1;
        if value < PRE_SCALE_MIN as u64 || value > PRE_SCALE_MAX as u64 {
            return None;
        }
        Some(Self(value as u8))
    }

    /// A register value, if it is one the chip takes (3..=255).
    pub const fn from_value(value: u8) -> Option<Self> {
        if value >= PRE_SCALE_MIN {
            Some(Self(value))
        } else {
            None
        }
    }

    /// The register value.
    pub const fn value(self) -> u8 {
        self.0
    }

    /// One PWM period in nanoseconds: `4096 × (value + 1) / 25 MHz` = `(value + 1) × 163 840`.
    pub const fn period_nanos(self) -> u32 {
        (self.0 as u32 + 1) * (COUNTS * 1_000 / (OSCILLATOR_HZ / 1_000_000))
    }

    /// The frequency the chip makes, in millihertz (1 525 878 for the default).
    pub const fn millihertz(self) -> u32 {
        ((OSCILLATOR_HZ as u64 * 1_000) / (COUNTS as u64 * (self.0 as u64 + 1))) as u32
    }
}

impl Default for Prescale {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prescale_follows_the_datasheet_formula_and_range() {
        // round(25e6 / (4096 × 200)) − 1 = 30: the power-up value is 200 Hz.
        assert_eq!(Prescale::from_hz(200).map(Prescale::value), Some(30));
        assert_eq!(Prescale::from_hz(1526).map(Prescale::value), Some(3));
        assert_eq!(Prescale::from_hz(1000).map(Prescale::value), Some(5));
        assert_eq!(Prescale::from_hz(24).map(Prescale::value), Some(253));
        assert_eq!(Prescale::from_hz(23), None);
        assert_eq!(Prescale::from_hz(1527), None);
        assert_eq!(Prescale::from_hz(0), None);
        assert_eq!(Prescale::from_hz(u32::MAX), None);
        assert_eq!(Prescale::from_value(2), None);
        assert_eq!(Prescale::from_value(255).map(Prescale::value), Some(255));
    }

    #[test]
    fn default_is_1526_hz_with_a_655_us_period() {
        assert_eq!(
            Prescale::from_hz(DEFAULT_FREQUENCY_HZ),
            Some(Prescale::DEFAULT)
        );
        assert_eq!(Prescale::DEFAULT.period_nanos(), 655_360);
        assert_eq!(Prescale::DEFAULT.millihertz(), 1_525_878);
        assert_eq!(Prescale(255).millihertz(), 23_841);
    }
}
