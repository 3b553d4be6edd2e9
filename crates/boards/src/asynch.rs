//! [`Pca9555Async`]: the [`Pca9555`](crate::Pca9555) driver on embedded-hal-async 1.0
//! (feature `async`). Same transactions, same order, same cache.

use embedded_hal_async::i2c::I2c;

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
