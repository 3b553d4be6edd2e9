//! A register model of the NXP PCA9685, 16 channels of 12-bit PWM: the PWM finger board's
//! chip. Register by register as the data sheet (Rev. 4, 2015) gives them, with its power-on
//! reset state.
//!
//! | register | what | power-up |
//! |---|---|---|
//! | [`MODE1`] (0x00) | `RESTART` (reads 1 while a restart is pending), `EXTCLK`, `AI`, `SLEEP`, `SUB1..3`, `ALLCALL` | `0x11`: asleep |
//! | [`MODE2`] (0x01) | `INVRT`, `OCH`, `OUTDRV`, `OUTNE` | `0x04` |
//! | 0x02..=0x05 | sub-addresses and the All Call address (stored, not answered) | `E2 E4 E8 E0` |
//! | [`LED0_ON_L`] + 4n .. + 3 (0x06..=0x45) | channel n: ON count, full ON (bit 4 of `ON_H`), OFF count, full OFF (bit 4 of `OFF_H`) | all 0 but `OFF_H` = `0x10`: full OFF |
//! | [`ALL_LED_ON_L`]..=[`ALL_LED_OFF_H`] (0xFA..=0xFD) | write the same byte into that register of every channel; read 0 | 0 |
//! | [`PRE_SCALE`] (0xFE) | the PWM frequency, `25 MHz / (4096 × (value + 1))`; writable only asleep, at least 3 | 30 (200 Hz) |
//!
//! **Writes.** A write frame is `[register, data…]`. With `AI` set the register pointer moves
//! on after each byte: from 0x45 to 0x00, and from 0xFE to 0x00 (the data sheet's "rolls over
//! to register 0"); without it every byte goes to the one register. Bits 7:5 of every `_H`
//! register are read-only 0. Writes to `PRE_SCALE` while awake are blocked, as on the chip; a
//! value below 3 becomes 3. Reserved registers (0x46..=0xF9) and `TEST_MODE` (0xFF) are
//! ignored.
//!
//! **Reads** start at the last register a write pointed to and move on as writes do.
//!
//! **Output.** What a channel's pin does, as [`Pca9685::high_counts`] (0..=4096 counts of the
//! 4096 of a period) and [`Pca9685::duty`] (the same on the 0..=4095 scale of `orch-boards`'
//! driver, where 4095 is 100 %):
//! - asleep ([`SLEEP`] set): every output 0 (the oscillator is off);
//! - `OE` pin high ([`Pca9685::set_output_enable`]`(false)`): `OUTNE` = 00, 0; `OUTNE` = 01
//!   with totem-pole outputs, 4096 (high); otherwise high-impedance, 0 (a gate pulled down);
//! - full OFF: 0 (it takes precedence over full ON); full ON: 4096; otherwise
//!   `(OFF − ON) mod 4096` counts, an OFF below the ON wrapping past the period's end, and
//!   `ON = OFF` 0 (the data sheet forbids it; the chip is seen to output nothing);
//! - [`INVRT`]: 4096 minus that (only while `OE` is low, as the data sheet says).
//!
//! **Sleep and restart** (data sheet 7.3.1.1). Going to sleep while any channel is not fully
//! off sets `RESTART`; with every channel fully off (an orderly shutdown) it clears it. Waking
//! with `RESTART` set leaves every output off ("held") until a 1 is written to `RESTART`
//! (which restarts the channels and clears it) or until any channel register is written
//! (which, with `OCH` = 0, also clears it). Writing `RESTART` while asleep does nothing.
//!
//! **Assumptions** (stated so tests can rely on them):
//! - Outputs change when the whole transaction completes, at its STOP, for every write (the
//!   chip does so with `OCH` = 0, this driver's setting; with `OCH` = 1 it would change at the
//!   ACKs, at most a few bit-times earlier). The chip then applies a new ON/OFF at the end of
//!   the output's LOW time (data sheet 7.3.4): up to one period ([`Pca9685::period_nanos`])
//!   after the STOP, not modelled.
//! - The oscillator's 500 µs start-up after waking is not modelled: outputs run from the STOP
//!   of the waking write. A driver must wait it anyway (`orch-boards` does).
//! - A "held" channel after a wake without restart outputs nothing; the data sheet does not
//!   say what it outputs, and nothing is the safe reading.
//! - `EXTCLK` is stored (sticky, as on the chip) but the model's frequency is always the
//!   internal 25 MHz one's. The sub-addresses and All Call are stored, not answered: the bus
//!   delivers to a device by its own address only.

/// Mode register 1.
pub const MODE1: u8 = 0x00;
/// Mode register 2.
pub const MODE2: u8 = 0x01;
/// Channel 0's first register (`LED0_ON_L`); channel n's four start at `0x06 + 4n`.
pub const LED0_ON_L: u8 = 0x06;
/// The last channel register (`LED15_OFF_H`).
pub const LED15_OFF_H: u8 = 0x45;
/// Writes every channel's `ON_L`.
pub const ALL_LED_ON_L: u8 = 0xFA;
/// Writes every channel's `ON_H`.
pub const ALL_LED_ON_H: u8 = 0xFB;
/// Writes every channel's `OFF_L`.
pub const ALL_LED_OFF_L: u8 = 0xFC;
/// Writes every channel's `OFF_H`.
pub const ALL_LED_OFF_H: u8 = 0xFD;
/// The prescaler.
pub const PRE_SCALE: u8 = 0xFE;

/// `MODE1` bit 7.
pub const RESTART: u8 = 0x80;
/// `MODE1` bit 6.
pub const EXTCLK: u8 = 0x40;
/// `MODE1` bit 5.
pub const AI: u8 = 0x20;
/// `MODE1` bit 4.
pub const SLEEP: u8 = 0x10;
/// `MODE1` bit 0.
pub const ALLCALL: u8 = 0x01;
/// `MODE2` bit 4.
pub const INVRT: u8 = 0x10;
/// `MODE2` bit 3.
pub const OCH: u8 = 0x08;
/// `MODE2` bit 2.
pub const OUTDRV: u8 = 0x04;
/// `MODE2` bits 1:0.
pub const OUTNE_MASK: u8 = 0x03;
/// Bit 4 of `LEDn_ON_H` (full ON) and `LEDn_OFF_H` (full OFF).
pub const FULL_ON_OFF: u8 = 0x10;

/// `MODE1` at power-up: asleep, answering All Call.
pub const POWER_UP_MODE1: u8 = SLEEP | ALLCALL;
/// `MODE2` at power-up: totem pole.
pub const POWER_UP_MODE2: u8 = OUTDRV;
/// `PRE_SCALE` at power-up (200 Hz).
pub const POWER_UP_PRE_SCALE: u8 = 30;
/// Counts in a PWM period.
pub const COUNTS: u16 = 4096;

/// One PCA9685 at a 7-bit I2C address.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Pca9685 {
    address: u8,
    /// `MODE1` without its `RESTART` bit (see `restart`).
    mode1: u8,
    mode2: u8,
    /// SUBADR1..3 and ALLCALLADR (0x02..=0x05).
    addresses: [u8; 4],
    /// The 64 channel registers, 0x06..=0x45.
    led: [u8; 64],
    pre_scale: u8,
    /// `RESTART` reads 1: channels a sleep held can be restarted.
    restart: bool,
    /// Awake with a restart pending: every output held off.
    held: bool,
    /// The `OE` pin is low (outputs enabled).
    output_enable: bool,
    pointer: u8,
}

impl Pca9685 {
    /// A chip at the 7-bit `address`, in its power-on reset state: asleep, every channel fully
    /// off, `OE` low (enabled).
    pub const fn new(address: u8) -> Self {
        let mut led = [0; 64];
        let mut i = 3;
        while i < 64 {
            led[i] = FULL_ON_OFF;
            i += 4;
        }
        Self {
            address,
            mode1: POWER_UP_MODE1,
            mode2: POWER_UP_MODE2,
            addresses: [0xE2, 0xE4, 0xE8, 0xE0],
            led,
            pre_scale: POWER_UP_PRE_SCALE,
            restart: false,
            held: false,
            output_enable: true,
            pointer: MODE1,
        }
    }

    /// Its 7-bit I2C address.
    pub const fn address(&self) -> u8 {
        self.address
    }

    /// Back to the power-on reset state (a power cycle or a software reset). The `OE` pin is
    /// wired outside the chip and stays as it is.
    pub fn reset(&mut self) {
        let oe = self.output_enable;
        *self = Self::new(self.address);
        self.output_enable = oe;
    }

    /// Drives the `OE` pin: `true` is low (outputs enabled), `false` high (the hardware stop:
    /// see the module notes for what the outputs do).
    pub fn set_output_enable(&mut self, enabled: bool) {
        self.output_enable = enabled;
    }

    /// Whether the `OE` pin is low (outputs enabled).
    pub const fn output_enabled(&self) -> bool {
        self.output_enable
    }

    /// `MODE1` as a read returns it (`RESTART` included).
    pub const fn mode1(&self) -> u8 {
        self.mode1 | if self.restart { RESTART } else { 0 }
    }

    /// `MODE2`.
    pub const fn mode2(&self) -> u8 {
        self.mode2
    }

    /// `PRE_SCALE`.
    pub const fn pre_scale(&self) -> u8 {
        self.pre_scale
    }

    /// Whether `SLEEP` is set (oscillator off, every output off).
    pub const fn sleeping(&self) -> bool {
        self.mode1 & SLEEP != 0
    }

    /// Whether channels are held off after a wake, waiting for a `RESTART`.
    pub const fn held(&self) -> bool {
        self.held
    }

    /// One PWM period in nanoseconds at the internal 25 MHz: `(PRE_SCALE + 1) × 163 840`.
    pub const fn period_nanos(&self) -> u64 {
        (self.pre_scale as u64 + 1) * 163_840
    }

    /// Channel `channel`'s four registers `[ON_L, ON_H, OFF_L, OFF_H]` (`channel` 0..=15).
    pub fn channel_registers(&self, channel: u8) -> [u8; 4] {
        let i = 4 * usize::from(channel & 15);
        [
            self.led[i],
            self.led[i + 1],
            self.led[i + 2],
            self.led[i + 3],
        ]
    }

    /// What the registers ask of channel `channel`, in counts of the period (0..=4096), before
    /// sleep, `OE` and `INVRT` (see [`high_counts`](Self::high_counts)).
    pub fn programmed_counts(&self, channel: u8) -> u16 {
        let [on_l, on_h, off_l, off_h] = self.channel_registers(channel);
        if off_h & FULL_ON_OFF != 0 {
            return 0;
        }
        if on_h & FULL_ON_OFF != 0 {
            return COUNTS;
        }
        let on = u16::from_le_bytes([on_l, on_h & 0x0F]);
        let off = u16::from_le_bytes([off_l, off_h & 0x0F]);
        (off + COUNTS - on) % COUNTS
    }

    /// How long channel `channel`'s pin is high, in counts of the 4096 of a period: 0 is never,
    /// 4096 always. See the module notes.
    pub fn high_counts(&self, channel: u8) -> u16 {
        if self.sleeping() || self.held {
            return 0;
        }
        if !self.output_enable {
            let totem_pole = self.mode2 & OUTDRV != 0;
            return if self.mode2 & OUTNE_MASK == 0b01 && totem_pole {
                COUNTS
            } else {
                0
            };
        }
        let counts = self.programmed_counts(channel);
        if self.mode2 & INVRT != 0 {
            COUNTS - counts
        } else {
            counts
        }
    }

    /// Channel `channel`'s output on the 0..=4095 scale of `orch-boards`' driver, where 4095
    /// is 100 %: `min(high_counts, 4095)` (so 4095/4096 also reads 4095).
    pub fn duty(&self, channel: u8) -> u16 {
        self.high_counts(channel).min(COUNTS - 1)
    }

    /// Every channel's [`duty`](Self::duty).
    pub fn duties(&self) -> [u16; 16] {
        core::array::from_fn(|c| self.duty(c as u8))
    }

    /// The channels whose pin is high some of the time, as bits (bit n is channel n).
    pub fn driven(&self) -> u16 {
        (0..16u8).fold(0, |m, c| m | (u16::from(self.high_counts(c) > 0) << c))
    }

    /// The register a read frame starts at (the last one a write pointed to).
    pub const fn pointer(&self) -> u8 {
        self.pointer
    }

    /// Reads one register without side effects.
    pub fn register(&self, register: u8) -> u8 {
        match register {
            MODE1 => self.mode1(),
            MODE2 => self.mode2,
            0x02..=0x05 => self.addresses[usize::from(register - 2)],
            LED0_ON_L..=LED15_OFF_H => self.led[usize::from(register - LED0_ON_L)],
            PRE_SCALE => self.pre_scale,
            _ => 0, // ALL_LED_* read 0; reserved registers and TEST_MODE too
        }
    }

    fn any_channel_running(&self) -> bool {
        (0..16u8).any(|c| self.programmed_counts(c) > 0)
    }

    fn set_register(&mut self, register: u8, value: u8) {
        match register {
            MODE1 => self.set_mode1(value),
            MODE2 => self.mode2 = value & 0x1F,
            0x02..=0x05 => self.addresses[usize::from(register - 2)] = value,
            LED0_ON_L..=LED15_OFF_H => {
                let i = usize::from(register - LED0_ON_L);
                self.led[i] = if i % 2 == 1 { value & 0x1F } else { value };
                self.pwm_register_written();
            }
            ALL_LED_ON_L..=ALL_LED_OFF_H => {
                let k = usize::from(register - ALL_LED_ON_L);
                let value = if k % 2 == 1 { value & 0x1F } else { value };
                for c in 0..16 {
                    self.led[4 * c + k] = value;
                }
                self.pwm_register_written();
            }
            PRE_SCALE if self.sleeping() => self.pre_scale = value.max(3),
            _ => {} // blocked PRE_SCALE while awake, reserved, TEST_MODE
        }
    }

    /// A channel register written (with `OCH` = 0, applied at the STOP): `RESTART` clears and
    /// nothing is held any more.
    fn pwm_register_written(&mut self) {
        if !self.sleeping() {
            self.restart = false;
            self.held = false;
        }
    }

    fn set_mode1(&mut self, value: u8) {
        let was_sleeping = self.sleeping();
        let extclk = (self.mode1 | value) & EXTCLK; // sticky
        self.mode1 = (value & !(RESTART | EXTCLK)) | extclk;
        let sleeping = self.sleeping();
        if sleeping && !was_sleeping {
            // Asleep with channels running: they can be restarted; an orderly shutdown first
            // (every channel fully off) clears RESTART.
            self.restart = self.any_channel_running();
            self.held = false;
        } else if !sleeping && was_sleeping {
            self.held = self.restart;
        }
        if value & RESTART != 0 && !sleeping && self.restart {
            self.restart = false;
            self.held = false;
        }
    }

    fn next(&self, register: u8) -> u8 {
        if self.mode1 & AI == 0 {
            return register;
        }
        match register {
            LED15_OFF_H | PRE_SCALE => MODE1,
            r => r.wrapping_add(1),
        }
    }

    /// One write frame as the bus delivers it (the bytes after the address byte): the register,
    /// then data bytes, auto-incrementing if `AI` is set. An empty frame changes nothing.
    pub fn write_frame(&mut self, bytes: &[u8]) {
        let Some((&register, data)) = bytes.split_first() else {
            return;
        };
        self.pointer = register;
        let mut r = register;
        for &byte in data {
            self.set_register(r, byte);
            r = self.next(r);
        }
    }

    /// One read frame: fills `buffer` from the register pointer, auto-incrementing if `AI` is
    /// set.
    pub fn read_frame(&self, buffer: &mut [u8]) {
        let mut r = self.pointer;
        for byte in buffer {
            *byte = self.register(r);
            r = self.next(r);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Awake with auto-increment, as a driver leaves it.
    fn awake() -> Pca9685 {
        let mut chip = Pca9685::new(0x40);
        chip.write_frame(&[MODE1, AI]);
        chip
    }

    #[test]
    fn power_up_is_asleep_with_every_channel_fully_off() {
        let chip = Pca9685::new(0x40);
        assert_eq!(chip.mode1(), 0x11);
        assert_eq!(chip.mode2(), 0x04);
        assert_eq!(chip.pre_scale(), 30);
        assert!(chip.sleeping());
        for c in 0..16 {
            assert_eq!(chip.channel_registers(c), [0, 0, 0, 0x10]);
        }
        assert_eq!(chip.duties(), [0; 16]);
        assert_eq!(chip.driven(), 0);
        let mut woken = chip.clone();
        woken.write_frame(&[MODE1, 0]);
        assert_eq!(woken.duties(), [0; 16], "awake, still every channel off");
    }

    #[test]
    fn nothing_is_output_while_asleep() {
        let mut chip = Pca9685::new(0x40);
        chip.write_frame(&[MODE1, SLEEP | AI]);
        chip.write_frame(&[0x06, 0, 0x10, 0, 0]); // ch 0 full ON, while asleep
        assert_eq!(chip.programmed_counts(0), 4096);
        assert_eq!(chip.high_counts(0), 0);
        chip.write_frame(&[MODE1, AI]);
        assert_eq!(chip.high_counts(0), 4096);
    }

    #[test]
    fn without_auto_increment_every_byte_goes_to_one_register() {
        let mut chip = Pca9685::new(0x40);
        chip.write_frame(&[0x06, 1, 2, 3]);
        assert_eq!(chip.channel_registers(0), [3, 0, 0, 0x10]);
    }

    #[test]
    fn counts_full_on_off_and_wrap() {
        let mut chip = awake();
        chip.write_frame(&[0x06, 0, 0, 0xE8, 0x03]); // ON 0, OFF 1000
        assert_eq!(chip.high_counts(0), 1000);
        chip.write_frame(&[0x0A, 0x00, 0x0F, 0xE8, 0x02]); // ch 1: ON 3840, OFF 744: wraps
        assert_eq!(chip.high_counts(1), 1000);
        chip.write_frame(&[0x0E, 0, 0x10, 0, 0]); // ch 2 full ON
        assert_eq!((chip.high_counts(2), chip.duty(2)), (4096, 4095));
        chip.write_frame(&[0x0E, 0, 0x10, 0, 0x10]); // full OFF wins over full ON
        assert_eq!(chip.high_counts(2), 0);
        chip.write_frame(&[0x12, 0, 0, 0xFF, 0x0F]); // ch 3: ON 0, OFF 4095
        assert_eq!((chip.high_counts(3), chip.duty(3)), (4095, 4095));
        chip.write_frame(&[0x16, 0x34, 0x01, 0x34, 0x01]); // ON = OFF: nothing
        assert_eq!(chip.high_counts(4), 0);
        // Reserved bits 7:5 of the _H registers read 0.
        chip.write_frame(&[0x1A, 0, 0xE0, 0, 0xE0]);
        assert_eq!(chip.channel_registers(5), [0, 0, 0, 0]);
        assert_eq!(chip.driven(), 0b1011);
    }

    #[test]
    fn auto_increment_wraps_from_0x45_and_from_pre_scale_to_mode1() {
        let mut chip = awake();
        chip.write_frame(&[0x42, 0, 0, 0x00, 0x08, AI | ALLCALL]);
        assert_eq!(chip.high_counts(15), 2048);
        assert_eq!(chip.mode1(), AI | ALLCALL);
        let mut chip = awake();
        chip.write_frame(&[MODE1, SLEEP | AI]);
        chip.write_frame(&[PRE_SCALE, 5, AI]); // PRE_SCALE, then MODE1: wakes
        assert_eq!((chip.pre_scale(), chip.sleeping()), (5, false));
        let mut buf = [0; 3];
        chip.read_frame(&mut buf);
        assert_eq!(
            buf,
            [5, AI, 0x04],
            "read from the pointer: PRE_SCALE, MODE1, MODE2"
        );
    }

    #[test]
    fn all_led_registers_load_every_channel_and_read_0() {
        let mut chip = awake();
        chip.write_frame(&[ALL_LED_ON_L, 0, 0, 0x00, 0x04]); // every channel 1024
        assert_eq!(chip.duties(), [1024; 16]);
        assert_eq!(chip.register(ALL_LED_OFF_H), 0);
        chip.write_frame(&[ALL_LED_OFF_H, FULL_ON_OFF]);
        assert_eq!(chip.duties(), [0; 16]);
        assert_eq!(chip.channel_registers(7), [0, 0, 0, 0x10]);
    }

    #[test]
    fn pre_scale_is_writable_only_asleep_and_at_least_3() {
        let mut chip = awake();
        chip.write_frame(&[PRE_SCALE, 100]);
        assert_eq!(chip.pre_scale(), 30, "blocked while awake");
        chip.write_frame(&[MODE1, SLEEP]);
        chip.write_frame(&[PRE_SCALE, 1]);
        assert_eq!(chip.pre_scale(), 3);
        assert_eq!(chip.period_nanos(), 655_360);
    }

    #[test]
    fn sleep_with_channels_running_sets_restart_and_holds_them_until_restart() {
        let mut chip = awake();
        chip.write_frame(&[0x06, 0, 0, 0x00, 0x08]); // ch 0 at half
        chip.write_frame(&[MODE1, SLEEP | AI]);
        assert_eq!(chip.mode1() & RESTART, RESTART);
        chip.write_frame(&[MODE1, RESTART | SLEEP | AI]); // RESTART while asleep: nothing
        assert_eq!(chip.mode1() & RESTART, RESTART);
        chip.write_frame(&[MODE1, AI]); // awake, but held
        assert!(chip.held());
        assert_eq!(chip.high_counts(0), 0);
        chip.write_frame(&[MODE1, RESTART | AI]);
        assert_eq!(chip.high_counts(0), 2048);
        assert_eq!(chip.mode1(), AI, "RESTART cleared");
    }

    #[test]
    fn a_channel_write_after_waking_also_ends_the_hold() {
        let mut chip = awake();
        chip.write_frame(&[0x06, 0, 0, 0x00, 0x08]);
        chip.write_frame(&[MODE1, SLEEP | AI]);
        chip.write_frame(&[MODE1, AI]);
        chip.write_frame(&[0x0A, 0, 0, 0x00, 0x01]);
        assert_eq!((chip.high_counts(0), chip.high_counts(1)), (2048, 256));
        assert_eq!(chip.mode1() & RESTART, 0);
    }

    #[test]
    fn orderly_shutdown_before_sleep_clears_restart() {
        let mut chip = awake();
        chip.write_frame(&[0x06, 0, 0, 0x00, 0x08]);
        chip.write_frame(&[ALL_LED_OFF_H, FULL_ON_OFF]);
        chip.write_frame(&[MODE1, SLEEP | AI]);
        assert_eq!(chip.mode1() & RESTART, 0);
        chip.write_frame(&[MODE1, AI]);
        assert!(!chip.held());
    }

    #[test]
    fn output_enable_high_and_invert() {
        let mut chip = awake();
        chip.write_frame(&[0x06, 0, 0, 0x00, 0x04]); // 1024
        chip.set_output_enable(false);
        assert_eq!(chip.duties(), [0; 16], "OUTNE 00: every output 0");
        chip.write_frame(&[MODE2, OUTDRV | 0b01]);
        assert_eq!(
            chip.high_counts(3),
            4096,
            "OUTNE 01, totem pole: every output 1"
        );
        chip.set_output_enable(true);
        chip.write_frame(&[MODE2, OUTDRV | INVRT]);
        assert_eq!((chip.high_counts(0), chip.high_counts(1)), (3072, 4096));
    }

    #[test]
    fn extclk_is_sticky_and_reset_restores_power_up() {
        let mut chip = awake();
        chip.write_frame(&[MODE1, EXTCLK | SLEEP]);
        chip.write_frame(&[MODE1, 0]);
        assert_eq!(chip.mode1() & EXTCLK, EXTCLK);
        chip.set_output_enable(false);
        chip.reset();
        assert!(!chip.output_enabled(), "OE is outside the chip");
        chip.set_output_enable(true);
        assert_eq!(chip, Pca9685::new(0x40));
    }
}
