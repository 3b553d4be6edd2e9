//! The drivers on embedded-hal-async 1.0 (feature `async`): [`Pca9555Async`] is the
//! [`Pca9555`](crate::Pca9555) driver, [`Pca9685Async`] the [`Pca9685`](crate::Pca9685) one.
//! Same transactions, same order, same cache: the bytes come from the same pure functions.

use embedded_hal_async::delay::DelayNs;
use embedded_hal_async::i2c::I2c;

use crate::pca9685::frames::{self as pwm_frames, State};
use crate::pca9685::registers::{OSCILLATOR_STARTUP_US, RESTART};
use crate::pca9685::{Prescale, CHANNELS};
use crate::{frames, Error};

/// One PCA9555 (or TCA9555) on an async bus; see [`Pca9555`](crate::Pca9555) for the
/// meaning of each method.
#[derive(Debug)]
pub struct Pca9555Async<I2C> {
    i2c: I2C,
    address: u8,
    last: Option<u16>,
}

/// The TCA9555 has the PCA9555's register map and addresses.
pub type Tca9555Async<I2C> = Pca9555Async<I2C>;

impl<I2C: I2c> Pca9555Async<I2C> {
    /// A driver for the device at 7-bit `address`. Does no bus traffic.
    pub fn new(i2c: I2C, address: u8) -> Self {
        Self {
            i2c,
            address,
            last: None,
        }
    }

    /// Outputs to 0 (`[0x02, 0x00, 0x00]`) FIRST, THEN all pins outputs
    /// (`[0x06, 0x00, 0x00]`), so no solenoid twitches at power-up.
    pub async fn init(&mut self) -> Result<(), Error<I2C::Error>> {
        self.last = None;
        self.i2c.write(self.address, &frames::outputs(0)).await?;
        self.i2c.write(self.address, &frames::ALL_OUTPUTS).await?;
        self.last = Some(0);
        Ok(())
    }

    /// All 16 outputs in one transaction `[0x02, lo, hi]`. Always writes.
    pub async fn set_outputs(&mut self, outputs: u16) -> Result<(), Error<I2C::Error>> {
        self.last = None;
        self.i2c
            .write(self.address, &frames::outputs(outputs))
            .await?;
        self.last = Some(outputs);
        Ok(())
    }

    /// Writes only when `outputs` differs from the last value written successfully.
    /// Returns whether it wrote.
    pub async fn update_outputs(&mut self, outputs: u16) -> Result<bool, Error<I2C::Error>> {
        if self.last == Some(outputs) {
            return Ok(false);
        }
        self.set_outputs(outputs).await.map(|()| true)
    }

    /// The last value written successfully, or `None` when unknown.
    pub fn last_written(&self) -> Option<u16> {
        self.last
    }

    /// Forgets the last written value, so the next update writes.
    pub fn invalidate(&mut self) {
        self.last = None;
    }

    /// Reads both output registers back.
    pub async fn read_outputs(&mut self) -> Result<u16, Error<I2C::Error>> {
        let mut buf = [0; 2];
        self.i2c
            .write_read(self.address, &frames::READ_OUTPUTS, &mut buf)
            .await?;
        Ok(frames::word(buf))
    }

    /// Reads the levels on all 16 pins.
    pub async fn read_inputs(&mut self) -> Result<u16, Error<I2C::Error>> {
        let mut buf = [0; 2];
        self.i2c
            .write_read(self.address, &frames::READ_INPUTS, &mut buf)
            .await?;
        Ok(frames::word(buf))
    }

    /// The device's 7-bit address.
    pub fn address(&self) -> u8 {
        self.address
    }

    /// Gives the bus back. Does no bus traffic.
    pub fn destroy(self) -> I2C {
        self.i2c
    }
}

/// One PCA9685 on an async bus; see [`Pca9685`](crate::Pca9685) for the meaning of each
/// method and the [`pca9685`](crate::pca9685) module for the bytes.
#[derive(Debug)]
pub struct Pca9685Async<I2C> {
    i2c: I2C,
    address: u8,
    state: State,
}

impl<I2C: I2c> Pca9685Async<I2C> {
    /// A driver for the chip at 7-bit `address`. Does no bus traffic.
    pub fn new(i2c: I2C, address: u8) -> Self {
        Self {
            i2c,
            address,
            state: State::UNKNOWN,
        }
    }

    /// Every channel fully off, then `hz` set asleep, then awake with auto-increment, then
    /// 500 µs on `delay`. A frequency outside 24..=1526 Hz is [`Error::Frequency`], nothing
    /// written.
    pub async fn init(
        &mut self,
        hz: u32,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<I2C::Error>> {
        let prescale = Prescale::from_hz(hz).ok_or(Error::Frequency { hz })?;
        self.init_prescale(prescale, delay).await
    }

    /// [`init`](Self::init) with the prescale given directly.
    pub async fn init_prescale(
        &mut self,
        prescale: Prescale,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<I2C::Error>> {
        self.state = State::UNKNOWN;
        let a = self.address;
        self.i2c.write(a, &pwm_frames::ALL_OFF).await?;
        self.i2c.write(a, &pwm_frames::MODE1_SLEEP).await?;
        self.i2c.write(a, &pwm_frames::pre_scale(prescale)).await?;
        self.i2c.write(a, &pwm_frames::MODE2_SETTING).await?;
        self.i2c.write(a, &pwm_frames::MODE1_AWAKE).await?;
        delay.delay_us(OSCILLATOR_STARTUP_US).await;
        self.state.commit(0, &[0; CHANNELS]);
        self.state.prescale = Some(prescale);
        Ok(())
    }

    /// One channel's duty in one 5-byte write, unless unchanged. Returns whether it wrote.
    pub async fn set_duty(&mut self, channel: u8, duty: u16) -> Result<bool, Error<I2C::Error>> {
        let Some(frame) = self.state.plan_duty(channel, duty)? else {
            return Ok(false);
        };
        let c = usize::from(channel);
        self.state.forget(c, c);
        self.i2c.write(self.address, &frame).await?;
        self.state.commit(c, &[duty]);
        Ok(true)
    }

    /// All 16 duties in one write of the run of changed channels. Returns whether it wrote.
    pub async fn set_duties(
        &mut self,
        duties: &[u16; CHANNELS],
    ) -> Result<bool, Error<I2C::Error>> {
        let Some((first, last, span)) = self.state.plan_duties(duties)? else {
            return Ok(false);
        };
        self.state.forget(first, last);
        self.i2c.write(self.address, span.bytes()).await?;
        self.state.commit(first, &duties[first..=last]);
        Ok(true)
    }

    /// Every channel fully off in one 2-byte write, whatever the cache says.
    pub async fn all_off(&mut self) -> Result<(), Error<I2C::Error>> {
        self.state.forget(0, CHANNELS - 1);
        self.i2c.write(self.address, &pwm_frames::ALL_OFF).await?;
        self.state.commit(0, &[0; CHANNELS]);
        Ok(())
    }

    /// Sleep: oscillator and every output off, registers kept.
    pub async fn sleep(&mut self) -> Result<(), Error<I2C::Error>> {
        self.i2c
            .write(self.address, &pwm_frames::MODE1_SLEEP)
            .await?;
        Ok(())
    }

    /// Read `MODE1`, wake, 500 µs, and `RESTART` if it read 1. Returns whether it restarted.
    pub async fn restart(&mut self, delay: &mut impl DelayNs) -> Result<bool, Error<I2C::Error>> {
        let mut mode1 = [0];
        self.i2c
            .write_read(self.address, &pwm_frames::READ_MODE1, &mut mode1)
            .await?;
        self.i2c
            .write(self.address, &pwm_frames::MODE1_AWAKE)
            .await?;
        delay.delay_us(OSCILLATOR_STARTUP_US).await;
        if mode1[0] & RESTART == 0 {
            return Ok(false);
        }
        self.i2c
            .write(self.address, &pwm_frames::MODE1_RESTART)
            .await?;
        Ok(true)
    }

    /// Channel `channel`'s duty as last written successfully, or `None` when unknown.
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

    /// The prescale the last successful init set.
    pub fn prescale(&self) -> Option<Prescale> {
        self.state.prescale
    }

    /// Forgets every channel's duty, so the next write to each goes out.
    pub fn invalidate(&mut self) {
        self.state.duties = [None; CHANNELS];
    }

    /// The chip's 7-bit address.
    pub fn address(&self) -> u8 {
        self.address
    }

    /// Gives the bus back. Does no bus traffic.
    pub fn destroy(self) -> I2C {
        self.i2c
    }
}
