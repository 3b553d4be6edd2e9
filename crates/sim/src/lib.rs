//! # orch-sim: the virtual robot
//!
//! A simulated piano robot, faithful in bus timing and mechanics, to test the whole chain
//! (MIDI in, interpreter, board writes, sound out) without hardware. Its parts:
//!
//! - [`Pca9555`] ([`pca9555`]): the finger board's I/O expander, register by register, with
//!   its power-up state (every pin an input: nothing drives until configured).
//! - [`Pca9685`] ([`pca9685`]): the PWM finger board's chip, 16 channels of 12-bit PWM, with
//!   its power-on reset state (asleep, every channel fully off), sleep and restart; it reports
//!   each channel's duty as the chip outputs it.
//! - [`VirtualBus`] ([`bus`]): an I2C bus with the boards on it (either kind, mixed), implementing
//!   [`embedded_hal::i2c::I2c`]. It counts bit-times at its [`BusClock`] (START, 9 bits a byte,
//!   repeated STARTs, STOP), serialises transactions in simulated time ([`SimTime`], in
//!   nanoseconds), NACKs absent addresses, and logs every write.
//! - [`Mechanics`] ([`mechanics`]): solenoids and keys, from pin edges to key-down and key-up
//!   sound events, with press and release delays, a minimum hold, and smears (a re-press before
//!   the key is back up).
//! - [`WindMechanics`] ([`wind`]): a wind robot's valve and fingers among the keys: the
//!   fingers' travel, a note that cracks when the valve opens before they settle, loudness by
//!   breath.
//! - [`Recorder`] and [`Performance`] ([`recorder`]): every write, edge and sound, with summary
//!   figures; comparable (`==`), serialisable (serde) and printable as stable text.
//!
//! [`VirtualRobot`] ([`robot`]) puts them together behind [`orch_core::FingerBoards`] and, on
//! [`VirtualRobot::bus_mut`], behind [`embedded_hal::i2c::I2c`].
//!
//! ```
//! use orch_core::{Instant, Interpreter};
//! use orch_sim::{SimTime, SoundKind, VirtualRobot};
//!
//! let mut robot = VirtualRobot::thesis();
//! robot.init().unwrap(); // configure the boards: 8 writes of 38 bit-times
//!
//! let mut brain = Interpreter::thesis();
//! let t = Instant::from_millis(10);
//! brain.feed_slice(&[0x90, 60, 100], t); // middle C
//! robot.set_time(t);
//! brain.flush(&mut robot).unwrap();
//!
//! let performance = robot.finish(Instant::from_millis(100));
//! let down = performance.sounds[0];
//! assert_eq!((down.key, down.kind), (24, SoundKind::Down));
//! // The write [0x02, 0x00, 0x01] takes 38 bit-times of 12 µs, then the key takes 15 ms.
//! assert_eq!(down.time, SimTime::from_micros(10_000 + 456 + 15_000));
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bus;
pub mod mechanics;
pub mod pca9555;
pub mod pca9685;
pub mod recorder;
pub mod robot;
pub mod wind;

pub use bus::{
    BusClock, BusError, BusStats, BusWrite, Chip, DutyChange, PinChange, SimTime, VirtualBus,
};
pub use mechanics::{
    KeyMechanics, Loudness, Mechanics, MechanicsConfig, MechanicsStats, Press, SoundEvent,
    SoundKind,
};
pub use pca9555::Pca9555;
pub use pca9685::Pca9685;
pub use recorder::{Performance, PinEdge, Recorder, Summary};
pub use robot::{Keep, SimConfig, VirtualRobot};
pub use wind::{Breath, WindMechanics};
