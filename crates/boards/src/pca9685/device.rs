//! [`Pca9685`]: one PCA9685 on a blocking embedded-hal 1.0 bus.

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;

use super::frames::{self, State};
use super::registers::{OSCILLATOR_STARTUP_US, RESTART};
use super::{Prescale, CHANNELS};
use crate::Error;

/// One PCA9685 driving up to 16 solenoids at 12-bit PWM duties. See the
/// [module notes](crate::pca9685) for the bytes of each call.
///
/// Owns the bus; share one between several devices with `embedded-hal-bus`.
#[derive(Debug)]
pub struct Pca9685<I2C> {
    i2c: I2C,
    address: u8,
    state: State,
}

impl<I2C: I2c> Pca9685<I2C> {
    /// A driver for the chip at 7-bit `address` (0x40..=0x7F). Does no bus traffic: call
    /// [`init`](Self::init) next.
    pub fn new(i2c: I2C, address: u8) -> Self {
        Self {
            i2c,
            address,
            state: State::UNKNOWN,
        }
    }

    /// Every channel fully off, then the PWM frequency `hz` set asleep, then awake with
    /// auto-increment, then a 500 µs wait on `delay` for the oscillator. See the
    /// [module notes](crate::pca9685#what-goes-on-the-wire).
    ///
    /// A frequency the chip cannot make (outside 24..=1526 Hz) is refused with
    /// [`Error::Frequency`] before anything is written. Safe to call again, for example after
    /// the board lost power: it turns every channel off.
    pub fn init(&mut self, hz: u32, delay: &mut impl DelayNs) -> Result<(), Error<I2C::Error>> {
        let prescale = Prescale::from_hz(hz).ok_or(Error::Frequency { hz })?;
        self.init_prescale(prescale, delay)
    }

    /// [`init`](Self::init) with the prescale given directly.
    pub fn init_prescale(
        &mut self,
        prescale: Prescale,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<I2C::Error>> {
        init(
            &mut self.i2c,
            self.address,
            &mut self.state,
            prescale,
            delay,
        )
    }

    /// Sets one channel's duty (0..=4095, see the [module notes](crate::pca9685#duty)) in one
    /// 5-byte write, unless the driver knows the channel already holds it. Returns whether it
    /// wrote. A channel past 15 or a duty past 4095 is refused, nothing written.
    pub fn set_duty(&mut self, channel: u8, duty: u16) -> Result<bool, Error<I2C::Error>> {
        set_duty(&mut self.i2c, self.address, &mut self.state, channel, duty)
    }

    /// Sets all 16 duties (channel `n` is `duties[n]`) in ONE write covering the channels from
    /// the first to the last that changed (4 bytes a channel, 65 bytes for all 16), so they
    /// change together at its STOP. Writes nothing when none changed. Returns whether it
    /// wrote. Any channel's duty past 4095 refuses the whole call, nothing written.
    ///
    /// Two changed channels far apart cost the whole run between them: 0 and 15 take one
    /// 65-byte write (596 bit-times), against two [`set_duty`](Self::set_duty) writes of 56.
    pub fn set_duties(&mut self, duties: &[u16; CHANNELS]) -> Result<bool, Error<I2C::Error>> {
        set_duties(&mut self.i2c, self.address, &mut self.state, duties)
    }

    /// Every channel fully off in one 2-byte write (`[ALL_LED_OFF_H, 0x10]`), whatever the
    /// cache says. For stopping.
    pub fn all_off(&mut self) -> Result<(), Error<I2C::Error>> {
        all_off(&mut self.i2c, self.address, &mut self.state)
    }

    /// Puts the chip to sleep (`[MODE1, SLEEP | AI]`): oscillator off, every output off, the
    /// channel registers kept (and so the cache). If any channel was running, the chip sets
    /// `RESTART` so that [`restart`](Self::restart) can bring them back.
    pub fn sleep(&mut self) -> Result<(), Error<I2C::Error>> {
        self.i2c.write(self.address, &frames::MODE1_SLEEP)?;
        Ok(())
    }

    /// Wakes the chip from [`sleep`](Self::sleep) as data sheet section 7.3.1.1 says: reads
    /// `MODE1`, clears `SLEEP` (`[MODE1, AI]`), waits 500 µs on `delay`, and if `RESTART` read
    /// 1 writes `[MODE1, RESTART | AI]`, which restarts every channel that was running with its
    /// duty. Returns whether it restarted.
    pub fn restart(&mut self, delay: &mut impl DelayNs) -> Result<bool, Error<I2C::Error>> {
        let mut mode1 = [0];
        self.i2c
            .write_read(self.address, &frames::READ_MODE1, &mut mode1)?;
        self.i2c.write(self.address, &frames::MODE1_AWAKE)?;
        delay.delay_us(OSCILLATOR_STARTUP_US);
        if mode1[0] & RESTART == 0 {
            return Ok(false);
        }
        self.i2c.write(self.address, &frames::MODE1_RESTART)?;
        Ok(true)
    }

    /// Channel `channel`'s duty as last written successfully, or `None` when unknown (before
    /// [`init`](Self::init), after a failed write, after [`invalidate`](Self::invalidate)) or
    /// when there is no such channel.
    pub fn duty(&self, channel: u8) -> Option<u16> {
        self.state
            .duties
            .get(usize::from(channel))
            .copied()
            .flatten()
    }

    /// Every channel's duty as last written successfully (`None`: unknown).
    pub fn duties(&self) -> [Option<u16>; CHANNELS] {
        self.state.duties
    }

    /// The prescale the last successful [`init`](Self::init) set.
    pub fn prescale(&self) -> Option<Prescale> {
        self.state.prescale
    }

    /// Forgets every channel's duty, so the next write to each goes out. Use it when the chip
    /// may have been reset behind the driver's back.
    pub fn invalidate(&mut self) {
        self.state.duties = [None; CHANNELS];
    }

    /// The chip's 7-bit address.
    pub fn address(&self) -> u8 {
        self.address
    }

    /// The bus, to use between writes (to set a simulated bus's time, say). A write that
    /// changes the channels behind the driver's back must be followed by
    /// [`invalidate`](Self::invalidate).
    pub fn bus_mut(&mut self) -> &mut I2C {
        &mut self.i2c
    }

    /// Gives the bus back. Does no bus traffic: turn the channels off first if that matters.
    pub fn destroy(self) -> I2C {
        self.i2c
    }
}

// One board's operations on a bus it does not own, shared by `Pca9685` and `Pca9685Set`.

pub(crate) fn init<I2C: I2c>(
    i2c: &mut I2C,
    address: u8,
    state: &mut State,
    prescale: Prescale,
    delay: &mut impl DelayNs,
) -> Result<(), Error<I2C::Error>> {
    *state = State::UNKNOWN;
    i2c.write(address, &frames::ALL_OFF)?;
    i2c.write(address, &frames::MODE1_SLEEP)?;
    i2c.write(address, &frames::pre_scale(prescale))?;
    i2c.write(address, &frames::MODE2_SETTING)?;
    i2c.write(address, &frames::MODE1_AWAKE)?;
    delay.delay_us(OSCILLATOR_STARTUP_US);
    state.commit(0, &[0; CHANNELS]);
    state.prescale = Some(prescale);
    Ok(())
}

pub(crate) fn set_duty<I2C: I2c>(
    i2c: &mut I2C,
    address: u8,
    state: &mut State,
    channel: u8,
    duty: u16,
) -> Result<bool, Error<I2C::Error>> {
    let Some(frame) = state.plan_duty(channel, duty)? else {
        return Ok(false);
    };
    let c = usize::from(channel);
    state.forget(c, c);
    i2c.write(address, &frame)?;
    state.commit(c, &[duty]);
    Ok(true)
}

pub(crate) fn set_duties<I2C: I2c>(
    i2c: &mut I2C,
    address: u8,
    state: &mut State,
    duties: &[u16; CHANNELS],
) -> Result<bool, Error<I2C::Error>> {
    let Some((first, last, span)) = state.plan_duties(duties)? else {
        return Ok(false);
    };
    state.forget(first, last);
    i2c.write(address, span.bytes())?;
    state.commit(first, &duties[first..=last]);
    Ok(true)
}

pub(crate) fn all_off<I2C: I2c>(
    i2c: &mut I2C,
    address: u8,
    state: &mut State,
) -> Result<(), Error<I2C::Error>> {
    state.forget(0, CHANNELS - 1);
    i2c.write(address, &frames::ALL_OFF)?;
    state.commit(0, &[0; CHANNELS]);
    Ok(())
}
