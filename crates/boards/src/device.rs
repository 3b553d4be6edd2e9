//! [`Pca9555`]: one PCA9555 / TCA9555 on a blocking embedded-hal 1.0 bus.

use embedded_hal::i2c::I2c;

use crate::{frames, Error};

/// One PCA9555 (or register-compatible TCA9555) driving up to 16 solenoids.
///
/// Owns the bus; share a bus between several devices with `embedded-hal-bus`, or use
/// [`FingerBoardSet`](crate::FingerBoardSet), which owns one bus and many boards.
#[derive(Debug)]
pub struct Pca9555<I2C> {
    i2c: I2C,
    address: u8,
    /// What the output registers hold, as far as this driver knows: `None` until [`init`]
    /// succeeds and after any failed write.
    ///
    /// [`init`]: Pca9555::init
    last: Option<u16>,
}

/// The TCA9555 has the PCA9555's register map and addresses.
pub type Tca9555<I2C> = Pca9555<I2C>;

impl<I2C: I2c> Pca9555<I2C> {
    /// A driver for the device at 7-bit `address` (see [`address`](crate::address)).
    /// Does no bus traffic: call [`init`](Self::init) next.
    pub fn new(i2c: I2C, address: u8) -> Self {
        Self {
            i2c,
            address,
            last: None,
        }
    }

    /// Makes all 16 pins outputs, driven low, without a twitch.
    ///
    /// After power-up the output registers hold 1s and every pin is an input. So it FIRST
    /// writes both output registers to 0 (`[0x02, 0x00, 0x00]`), THEN makes every pin an
    /// output (`[0x06, 0x00, 0x00]`): a pin never drives a 1. If the first write fails the
    /// second is not tried and the pins stay (safe) inputs. Safe to call again, for example
    /// after the board lost power: it releases every finger.
    pub fn init(&mut self) -> Result<(), Error<I2C::Error>> {
        self.last = None;
        self.i2c.write(self.address, &frames::outputs(0))?;
        self.i2c.write(self.address, &frames::ALL_OUTPUTS)?;
        self.last = Some(0);
        Ok(())
    }

    /// Writes all 16 outputs in one transaction `[0x02, lo, hi]` (bit `n` is output `n`;
    /// bits 0..=7 are port 0). Always writes; see [`update_outputs`](Self::update_outputs)
    /// to skip unchanged values.
    pub fn set_outputs(&mut self, outputs: u16) -> Result<(), Error<I2C::Error>> {
        self.last = None;
        self.i2c.write(self.address, &frames::outputs(outputs))?;
        self.last = Some(outputs);
        Ok(())
    }

    /// Like [`set_outputs`](Self::set_outputs), but does nothing when `outputs` is the last
    /// value written successfully. Returns whether it wrote.
    pub fn update_outputs(&mut self, outputs: u16) -> Result<bool, Error<I2C::Error>> {
        if self.last == Some(outputs) {
            return Ok(false);
        }
        self.set_outputs(outputs).map(|()| true)
    }

    /// The last value written successfully, or `None` when unknown (before [`init`](Self::init),
    /// after a failed write or [`invalidate`](Self::invalidate)).
    pub fn last_written(&self) -> Option<u16> {
        self.last
    }

    /// Forgets the last written value, so the next [`update_outputs`](Self::update_outputs)
    /// writes. Use it when the board may have been reset behind the driver's back.
    pub fn invalidate(&mut self) {
        self.last = None;
    }

    /// Reads both output registers back (`write_read` of `[0x02]`, two bytes).
    pub fn read_outputs(&mut self) -> Result<u16, Error<I2C::Error>> {
        let mut buf = [0; 2];
        self.i2c
            .write_read(self.address, &frames::READ_OUTPUTS, &mut buf)?;
        Ok(frames::word(buf))
    }

    /// Reads the levels on all 16 pins (`write_read` of `[0x00]`, two bytes).
    pub fn read_inputs(&mut self) -> Result<u16, Error<I2C::Error>> {
        let mut buf = [0; 2];
        self.i2c
            .write_read(self.address, &frames::READ_INPUTS, &mut buf)?;
        Ok(frames::word(buf))
    }

    /// The device's 7-bit address.
    pub fn address(&self) -> u8 {
        self.address
    }

    /// Gives the bus back. Does no bus traffic: release the fingers first if that matters.
    pub fn destroy(self) -> I2C {
        self.i2c
    }
}
