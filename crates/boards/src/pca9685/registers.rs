//! The PCA9685 register map and bits (NXP PCA9685 product data sheet, Rev. 4, 16 April 2015:
//! table 4 "register summary", tables 5–7, sections 7.3.1–7.3.5).
//!
//! Each of the 16 channels has four registers, `LEDn_ON_L`, `LEDn_ON_H`, `LEDn_OFF_L`,
//! `LEDn_OFF_H`, at `LED0_ON_L + 4 × n`: a 12-bit ON count and a 12-bit OFF count within the
//! 4096 counts of a PWM period, and in bit 4 of each `_H` register a "full ON" / "full OFF" bit
//! ([`FULL_ON_OFF`]). Full OFF takes precedence over full ON. With [`AI`] set in `MODE1`, the
//! register pointer moves on after each data byte, so one write `[LEDn_ON_L, on_l, on_h, off_l,
//! off_h]` sets a whole channel; past `LED15_OFF_H` (0x45) it wraps to `MODE1`, and from
//! `ALL_LED_ON_L` it runs to `PRE_SCALE` and wraps to `MODE1` too. Without `AI` every data byte
//! goes to the one register the command byte named.

/// Mode register 1: restart, external clock, auto-increment, sleep, sub and all-call address
/// enables. Power-up value [`MODE1_POWER_UP`].
pub const MODE1: u8 = 0x00;
/// Mode register 2: output inversion, change on STOP or ACK, totem pole or open drain, and
/// what the outputs do while `OE` is high. Power-up value [`MODE2_POWER_UP`].
pub const MODE2: u8 = 0x01;
/// I2C sub-address 1 (the device answers it when `MODE1` [`SUB1`] is set).
pub const SUBADR1: u8 = 0x02;
/// I2C sub-address 2.
pub const SUBADR2: u8 = 0x03;
/// I2C sub-address 3.
pub const SUBADR3: u8 = 0x04;
/// The LED All Call I2C address (power-up 0xE0 in 8-bit form, 0x70 in 7-bit form).
pub const ALLCALLADR: u8 = 0x05;
/// Channel 0's ON count, low 8 bits. Channel `n`'s four registers start at
/// `LED0_ON_L + 4 × n` ([`led_on_l`]).
pub const LED0_ON_L: u8 = 0x06;
/// Channel 0's ON count, high 4 bits (3:0), and its full-ON bit (bit 4).
pub const LED0_ON_H: u8 = 0x07;
/// Channel 0's OFF count, low 8 bits.
pub const LED0_OFF_L: u8 = 0x08;
/// Channel 0's OFF count, high 4 bits (3:0), and its full-OFF bit (bit 4).
pub const LED0_OFF_H: u8 = 0x09;
/// Registers per channel.
pub const REGISTERS_PER_CHANNEL: u8 = 4;
/// The last channel register, channel 15's `OFF_H`; auto-increment wraps from it to `MODE1`.
pub const LED15_OFF_H: u8 = 0x45;
/// Loads every channel's `ON_L` (write-only; reads 0).
pub const ALL_LED_ON_L: u8 = 0xFA;
/// Loads every channel's `ON_H` (write-only; reads 0).
pub const ALL_LED_ON_H: u8 = 0xFB;
/// Loads every channel's `OFF_L` (write-only; reads 0).
pub const ALL_LED_OFF_L: u8 = 0xFC;
/// Loads every channel's `OFF_H` (write-only; reads 0): [`FULL_ON_OFF`] here turns every
/// channel fully off in one 2-byte write, whatever `AI` says.
pub const ALL_LED_OFF_H: u8 = 0xFD;
/// The PWM frequency prescaler. Writable only while `MODE1` [`SLEEP`] is set (writes are
/// blocked otherwise). Power-up value [`PRE_SCALE_POWER_UP`].
pub const PRE_SCALE: u8 = 0xFE;
/// Enters test mode: never written by this driver (the data sheet reserves it).
pub const TEST_MODE: u8 = 0xFF;

/// `MODE1` bit 7: reads 1 when channels that were running are held by a sleep and can be
/// restarted; writing 1 restarts them and clears it (writing 0 has no effect). Data sheet
/// section 7.3.1.1.
pub const RESTART: u8 = 0x80;
/// `MODE1` bit 6: use the EXTCLK pin's clock. Sticky: only a power cycle or a software reset
/// clears it. Never set by this driver.
pub const EXTCLK: u8 = 0x40;
/// `MODE1` bit 5: register auto-increment.
pub const AI: u8 = 0x20;
/// `MODE1` bit 4: low-power mode, oscillator off; every output is off while it is set.
pub const SLEEP: u8 = 0x10;
/// `MODE1` bit 3: answer I2C sub-address 1.
pub const SUB1: u8 = 0x08;
/// `MODE1` bit 2: answer I2C sub-address 2.
pub const SUB2: u8 = 0x04;
/// `MODE1` bit 1: answer I2C sub-address 3.
pub const SUB3: u8 = 0x02;
/// `MODE1` bit 0: answer the LED All Call address.
pub const ALLCALL: u8 = 0x01;

/// `MODE2` bit 4: invert the output logic.
pub const INVRT: u8 = 0x10;
/// `MODE2` bit 3: outputs change on ACK (1) instead of on STOP (0, the power-up value).
pub const OCH: u8 = 0x08;
/// `MODE2` bit 2: totem-pole outputs (1, the power-up value) instead of open drain.
pub const OUTDRV: u8 = 0x04;
/// `MODE2` bits 1:0 (`OUTNE`): what the outputs do while the `OE` pin is high. `00` (the
/// power-up value): every output 0 (with `INVRT` = 0: off).
pub const OUTNE_MASK: u8 = 0x03;
/// `MODE2` bit 1, `OUTNE[1]`: 1 makes the outputs high-impedance while `OE` is high.
pub const OUTNE_1: u8 = 0x02;
/// `MODE2` bit 0, `OUTNE[0]`: with `OUTNE[1]` = 0, outputs 1 (totem pole) or high-impedance
/// (open drain) while `OE` is high.
pub const OUTNE_0: u8 = 0x01;

/// Bit 4 of `LEDn_ON_H` (full ON: the output is always on, the OFF count is ignored) and of
/// `LEDn_OFF_H` (full OFF: always off, takes precedence over full ON).
pub const FULL_ON_OFF: u8 = 0x10;

/// `MODE1` at power-up: asleep, answering All Call (`SLEEP | ALLCALL`).
pub const MODE1_POWER_UP: u8 = SLEEP | ALLCALL;
/// `MODE2` at power-up: totem pole, change on STOP, not inverted, outputs 0 while `OE` is high.
pub const MODE2_POWER_UP: u8 = OUTDRV;
/// `PRE_SCALE` at power-up: 30 (200 Hz with the 25 MHz oscillator).
pub const PRE_SCALE_POWER_UP: u8 = 0x1E;
/// Every `LEDn_OFF_H` at power-up: full OFF. Every other channel register powers up 0.
pub const LED_OFF_H_POWER_UP: u8 = FULL_ON_OFF;

/// The internal oscillator, 25 MHz.
pub const OSCILLATOR_HZ: u32 = 25_000_000;
/// Counts in one PWM period (12 bits).
pub const COUNTS: u32 = 4096;
/// The smallest value `PRE_SCALE` takes (the chip forces anything below it to 3).
pub const PRE_SCALE_MIN: u8 = 3;
/// The largest value `PRE_SCALE` takes.
pub const PRE_SCALE_MAX: u8 = 0xFF;
/// How long the oscillator takes, at most, to run after `SLEEP` is cleared (data sheet
/// section 7.3.1 remark: 500 µs).
pub const OSCILLATOR_STARTUP_US: u32 = 500;

/// The address of channel `channel`'s first register (`LEDn_ON_L`), for `channel` 0..=15.
pub const fn led_on_l(channel: u8) -> u8 {
    LED0_ON_L + REGISTERS_PER_CHANNEL * channel
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_registers_are_four_apart_up_to_0x45() {
        assert_eq!(led_on_l(0), 0x06);
        assert_eq!(led_on_l(1), 0x0A);
        assert_eq!(led_on_l(15), 0x42);
        assert_eq!(led_on_l(15) + 3, LED15_OFF_H);
        assert_eq!(
            [LED0_ON_H, LED0_OFF_L, LED0_OFF_H],
            [LED0_ON_L + 1, LED0_ON_L + 2, LED0_ON_L + 3]
        );
    }

    #[test]
    fn all_led_registers_are_a_run_before_pre_scale() {
        assert_eq!(
            [ALL_LED_ON_H, ALL_LED_OFF_L, ALL_LED_OFF_H, PRE_SCALE],
            [
                ALL_LED_ON_L + 1,
                ALL_LED_ON_L + 2,
                ALL_LED_ON_L + 3,
                ALL_LED_ON_L + 4
            ]
        );
    }
}
