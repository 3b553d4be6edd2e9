//! The status LED (the Pico's own, GP25): what a builder sees without a computer.
//!
//! - Off: all is well and nothing comes in.
//! - A short flash ([`FLASH_US`]) for MIDI coming in, by DIN or USB: the Pico hears its sender.
//! - Blinking, about 4 times a second (on and off for [`BLINK_HALF_US`] each): a fault. A
//!   finger board does not answer (it is set aside and tried again every 10 ms; the blinking
//!   stops once every board answers), and for [`AFTER_RESET_US`] after the watchdog reset the
//!   Pico (its firmware hung, and every key was released at power-up). A fault hides the
//!   activity flashes.

use embassy_rp::gpio::{Level, Output};

/// How long the LED flashes for MIDI coming in.
pub const FLASH_US: u64 = 20_000;
/// Half a fault blink: 2¹⁷ µs (131 ms), so the phase is a bit of the clock.
pub const BLINK_HALF_US: u64 = 1 << 17;
/// How long a watchdog reset is shown as a fault.
pub const AFTER_RESET_US: u64 = 2_000_000;

/// The status LED and what it shows.
pub struct Led<'d> {
    pin: Output<'d>,
    /// The activity flash lasts until then (µs).
    flash_until: u64,
    /// A watchdog reset is shown until then (µs).
    fault_until: u64,
}

impl<'d> Led<'d> {
    /// The LED, off; showing a fault for [`AFTER_RESET_US`] from `now` if the watchdog reset
    /// the Pico.
    pub fn new(pin: Output<'d>, now: u64, after_watchdog_reset: bool) -> Self {
        let fault_until = if after_watchdog_reset {
            now + AFTER_RESET_US
        } else {
            0
        };
        Self {
            pin,
            flash_until: 0,
            fault_until,
        }
    }

    /// MIDI came in at `at` (µs).
    pub fn activity(&mut self, at: u64) {
        self.flash_until = self.flash_until.max(at + FLASH_US);
    }

    /// Sets the LED for `now` (µs), `fault` saying whether a board is set aside, and returns
    /// when it next changes by itself (µs), if it will.
    pub fn show(&mut self, now: u64, fault: bool) -> Option<u64> {
        let (on, next) = if fault || now < self.fault_until {
            let on = (now / BLINK_HALF_US).is_multiple_of(2);
            (on, Some((now / BLINK_HALF_US + 1) * BLINK_HALF_US))
        } else if now < self.flash_until {
            (true, Some(self.flash_until))
        } else {
            (false, None)
        };
        self.pin
            .set_level(if on { Level::High } else { Level::Low });
        next
    }
}
