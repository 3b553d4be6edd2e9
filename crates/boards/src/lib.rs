//! embedded-hal 1.0 drivers for orch's finger boards: NXP PCA9555 and the register-compatible
//! TI TCA9555, 16-bit I2C I/O expanders, each driving up to 16 key solenoids on or off; and
//! the NXP PCA9685, 16 channels of 12-bit PWM, for keys played at a strength.
//!
//! - [`Pca9555`] drives one device: [`init`](Pca9555::init), then
//!   [`set_outputs`](Pca9555::set_outputs) / [`update_outputs`](Pca9555::update_outputs).
//! - [`FingerBoardSet`] owns one bus and `N` boards and implements
//!   [`orch_core::FingerBoards`], so `orch_core::FingerFrame::flush` can write to real boards.
//! - [`MixedBoardSet`] owns one bus with boards of both kinds ([`orch_core::BoardKind`]): each
//!   written with its own driver's bytes and cache, on/off frames and duties alike.
//! - [`registers`] holds the PCA9555's datasheet register map, [`address`] the address helpers.
//! - [`Pca9685`] ([`pca9685`]) drives one PWM board: [`init`](Pca9685::init) at a PWM
//!   frequency, then [`set_duty`](Pca9685::set_duty) (one 5-byte write a key change) or
//!   [`set_duties`](Pca9685::set_duties) (one write for a board's changed channels),
//!   [`all_off`](Pca9685::all_off), [`sleep`](Pca9685::sleep), [`restart`](Pca9685::restart).
//!   Its module notes give every byte, the duty mapping, the power-up story and why the default
//!   frequency is 1526 Hz. [`Pca9685Set`] owns one bus and `N` PWM boards, a cache each; it
//!   also implements [`orch_core::FingerBoards`]: `write_duties` writes the duties the core's
//!   strike-and-hold profile plays (`Interpreter::flush_duties`), `write_board` an on/off
//!   frame (a set bit is a channel fully on).
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
//! For the PCA9685, eldruin's `pwm-pca9685` (1.0, embedded-hal 1.0, the reference Rust driver)
//! was read through. Its single-channel write is the one we want (`set_channel_on_off`: 5
//! bytes with auto-increment) and it writes all 16 channels in one transaction. It does not
//! serve, for one reason that decides it and three that would each cost a wrapper:
//! - its `async` feature *replaces* the blocking API (it is generated with `maybe-async-cfg`,
//!   the blocking `impl` under `cfg(not(feature = "async"))`): one build has one or the
//!   other. Cargo unifies features across a workspace, so the Pico firmware asking for async
//!   would take the blocking driver away from the host's `orch-io`. This crate offers both at
//!   once;
//! - no init sequence that turns every channel fully off before touching the mode and
//!   prescale registers: `new` writes nothing, `set_prescale` sleeps and wakes the
//!   oscillator, and turning every channel off first (`Channel::All`) is left to the caller;
//! - no per-channel cache that skips unchanged writes and forgets a channel whose write
//!   failed, and no write of only the changed run of channels (its `set_all_channels` is
//!   always 65 bytes);
//! - a prescale is a bare `u8` and a bad value an untyped `InvalidInputData`; a frequency the
//!   chip cannot make must be a typed error here, since `robot.toml` asks for one in Hz.
//!
//! It also brings `nb` and the `maybe-async-cfg` proc macro. Our PCA9685 driver is about 150
//! lines over the same traits, its bytes built once in pure functions for both drivers.
//!
//! # Cargo features
//!
//! - `async` (off by default): adds `asynch::Pca9555Async` and `asynch::Pca9685Async`, the
//!   same drivers on `embedded-hal-async` 1.0's `I2c` and `DelayNs` (for embassy and similar
//!   executors), beside the blocking ones. Pulls in `embedded-hal-async`.
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
mod mixed;
pub mod pca9685;
pub mod registers;
mod set;

pub use device::{Pca9555, Tca9555};
pub use error::Error;
pub use mixed::MixedBoardSet;
pub use pca9685::{Pca9685, Pca9685Set};
pub use set::FingerBoardSet;
