//! embedded-hal 1.0 drivers for orch's finger boards: NXP PCA9555 and the register-compatible
//! TI TCA9555, 16-bit I2C I/O expanders, each driving up to 16 key solenoids.
//!
//! - [`Pca9555`] drives one device: [`init`](Pca9555::init), then
//!   [`set_outputs`](Pca9555::set_outputs) / [`update_outputs`](Pca9555::update_outputs).
//! - [`FingerBoardSet`] owns one bus and `N` boards and implements
//!   [`orch_core::FingerBoards`], so `orch_core::FingerFrame::flush` can write to real boards.
//! - [`registers`] holds the datasheet's register map, [`address`] the address helpers.
//!
//! # What goes on the wire
//!
//! - **Initialisation**, per board: FIRST `[0x02, 0x00, 0x00]` (both output registers to 0),
//!   THEN `[0x06, 0x00, 0x00]` (all 16 pins outputs). The power-up output value is all 1s and
//!   every pin starts as an input; configuring first would energise every solenoid until the
//!   next write. If the first write fails the pins stay inputs.
//! - **A key change**: one transaction `[0x02, lo, hi]` to the one board it concerns (bits
//!   0..=7 on port 0, 8..=15 on port 1): about 38 bit times, 95 µs at 400 kHz.
//! - **Nothing changed**: nothing is written. Each driver caches the last value written
//!   successfully per board; a failed write forgets it, so the next write retries.
//!
//! The driver never retries by itself and never blocks beyond the bus call: every error comes
//! back as [`Error`], with [`Error::is_nack`] and [`Error::i2c_kind`] for the caller to decide.
//!
//! # Why not an existing crate
//!
//! Checked on crates.io: `port-expander` (0.6) and `pca9555` (0.1.1). Both are built for
//! pin-at-a-time GPIO: they split the device into 16 pin objects sharing the driver through
//! a mutex, while a finger board is written as one 16-bit frame. Neither, as documented,
//! promises what this project needs exactly: both ports in one `[0x02, lo, hi]`
//! transaction, an initialisation that zeroes the output registers before it makes the pins
//! outputs, a cache that skips unchanged writes per board, and a set of boards on one bus.
//! `pca9555` also always pulls in `embassy-sync` and `embedded-hal-async`. What we need is a
//! few dozen lines over `embedded_hal::i2c::I2c`, tested byte for byte here, so we own it.
//!
//! # Cargo features
//!
//! - `async` (off by default): adds `asynch::Pca9555Async`, the same driver on
//!   `embedded-hal-async` 1.0's `I2c` (for embassy and similar executors). Pulls in
//!   `embedded-hal-async`.
//!
//! With no features the crate is `no_std`, allocation-free and has no `unsafe`.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod address;
#[cfg(feature = "async")]
pub mod asynch;
mod device;
mod error;
mod frames;
pub mod registers;
mod set;

pub use device::{Pca9555, Tca9555};
pub use error::Error;
pub use set::FingerBoardSet;
