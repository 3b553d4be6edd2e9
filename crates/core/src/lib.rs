//! # orch-core: the one brain of a MIDI-driven solenoid instrument
//!
//! `no_std`, allocation-free and I/O-free. It turns a live MIDI 1.0 byte stream into writes
//! to finger boards (16 solenoid outputs each), with the safety a real robot needs: no key
//! stays down because input stopped, no solenoid is held long enough to overheat, and a
//! repeated note always lifts, rests and strikes again.
//!
//! - [`Decoder`]: the MIDI 1.0 stream decoder, exact to the specification (running status,
//!   real-time bytes anywhere, SysEx, undefined status bytes), with counters.
//! - [`Interpreter`]: decoded messages plus the current time in, a [`FingerFrame`] out. Maps
//!   notes to keys ([`KeyRange`], [`OutOfRange`]) and keys to fingers ([`Layout`]), keeps track
//!   of which notes hold each key, and runs the safety guard ([`GuardConfig`]).
//! - [`ConfigSource`]: where the interpreter finds its [`Config`]: in itself (any configuration,
//!   chosen at run time), or in a constant such as [`Thesis`] (no RAM, and the compiler folds
//!   it into the code: for MCUs).
//! - [`HeldNotes`]: where the interpreter records which notes are on ([`NoteTable`] on hosts,
//!   [`NotePool`] on small MCUs).
//! - [`NoteEvent`]: what became of each note (struck, waiting, joined, dropped and why),
//!   handed to a [`NoteSink`] by the `*_with` methods as it is decided.
//! - [`Dynamics`]: velocity as strike strength on PWM boards: each press a strike at the
//!   velocity's duty on the key's curve ([`Touch`]), then a hold ([`dynamics`]).
//! - [`Strikes`]: strike groups (drums, mallets) beside or instead of the keyboard: a note
//!   fires its output for a pulse that ends by itself ([`strike`]).
//! - [`FingerBoards`]: the one output trait, implemented by real boards (`orch-boards`), the
//!   virtual robot and the [`Recording`] test double.
//!
//! Time is passed in ([`Instant`], microseconds); the core never reads a clock, a file or a bus.
//!
//! ```
//! use orch_core::{Instant, Interpreter, Recording};
//!
//! let mut robot = Interpreter::thesis();
//! let mut boards = Recording::<8>::new();
//! robot.feed_slice(&[0x90, 60, 100], Instant::from_micros(0)); // middle C down
//! robot.flush(&mut boards).unwrap();
//! // Key 60 − 36 = 24: board 1 (0x22), bit 8.
//! assert_eq!(boards.outputs(1), 1 << 8);
//! robot.all_off(Instant::from_millis(5));
//! robot.flush(&mut boards).unwrap();
//! assert_eq!(boards.outputs(1), 0);
//! ```
//!
//! ## Memory
//!
//! Sized for the thesis's ATmega16 (1 KB of SRAM for everything, stack included). For 4 boards
//! and 61 keys, on a 64-bit host with its padding (`tests/memory_budget.rs` checks the totals):
//!
//! | part | bytes |
//! |---|---|
//! | the 61 keys' phase, 32-bit timestamp and velocity (the guard's memory), and the 16-byte mask of keys whose timers run | 384 |
//! | the 61 keys' heat for the duty limit (feature `duty-limit`, off on the ATmega16) | 122 (+6 padding) |
//! | held notes, [`NotePool<32>`](NotePool) (for MCUs: 32 notes played or sustained at once, twice the power budget) | 97 |
//! | held notes, [`NoteTable`] (the default: every channel of every note, played and sustained, exact under any load) | 512 |
//! | frame 18 (with its mask of the boards touched since the last flush), decoder 12 (28 with `stats`: its counters), clock 8, last input 4 and kept deadlines 10 (32-bit, see below), pedals and flags | ≈ 60 |
//! | the configuration (none with a constant one: [`Thesis`]) | 68 |
//! | the statistics and the decoder's counters (feature `stats`, off on the ATmega16) | 88 (+8 padding) |
//! | dynamics (feature `dynamics`, off on the ATmega16): the configuration's per-key [`Touch`] table and strike time (772), the duties last written to 4 boards (128) | 900 |
//! | strike groups (feature `strike`, off on the ATmega16): every key's pulse (1536), the sparse groups' note maps (512) and leads (512), the lead times (512), the dampers (128) and the groups, in the configuration; the dampers due (16) and the skipped count | 3260 |
//! | a fingered group (feature `wind`, off on the ATmega16): its table of 48 fingerings and figures, in the configuration (212); the notes held and the note playing (40) | 252 |
//! | `Interpreter<4, 61, NotePool<32>>` without `duty-limit` and `stats` | 616 |
//! | **`Interpreter<4, 61, NotePool<32>, Thesis>` without `duty-limit` and `stats`: the ATmega16 build** | **544** |
//! | **[`Interpreter`] with [`NoteTable`], the duty limit, the statistics, dynamics, strike groups and a fingered group: the host's** | **5652** |
//!
//! AVR has no padding, so the ATmega16 figure is a few bytes lower (536). The [`Decoder`]
//! alone takes 12 bytes (28 with `stats`).
//!
//! Time is passed in as 64-bit [`Instant`]s, but the interpreter keeps its deadlines and the
//! time of the last input in 32 bits (the low bits of the clock, compared by wrapping
//! difference; exact while they lie within 2³¹ µs of the clock, which a jump of the clock past
//! that preserves by marking them passed): on an 8-bit MCU every byte's work on time is then
//! 32-bit. An 8-bit MCU can go further with the `*_low32` methods
//! ([`Interpreter::feed_low32`], [`Interpreter::tick_low32`],
//! [`Interpreter::next_deadline_low32`]): it passes only the low 32 bits of its clock, and the
//! interpreter keeps its clock as two 32-bit halves, so that a byte's time arithmetic is 32-bit
//! end to end (exact while the calls come less than 2³⁰ µs apart).
//!
//! ## Cargo features
//!
//! The crate is always `no_std` and allocation-free.
//!
//! - `duty-limit` (default): the guard's per-key duty limit ([`DutyLimit`]), 2 bytes of RAM a
//!   key. The ATmega16 firmware builds without it (its 1 KB of SRAM has no room); its hold
//!   limit and watchdog still apply.
//! - `stats` (default): [`Interpreter::stats`] counts what became of the notes ([`Stats`],
//!   64 bytes of RAM and the code that counts), and the [`Decoder`] counts bytes, messages,
//!   dropped and abandoned ones ([`Counters`], 16 bytes and four 32-bit increments a byte).
//!   Without it every count reads 0; the messages and the [`NoteEvent`]s, which carry the
//!   same account note by note, are unchanged. The ATmega16 firmware builds without it.
//! - `dynamics` (default): a press played as a profile of PWM duties, strike then hold, from
//!   the note's velocity ([`Config::dynamics`], [`dynamics`], [`Interpreter::flush_duties`]),
//!   and a guard that counts current and energy instead of keys. 900 bytes of RAM with a
//!   configuration in RAM (its per-key table), 128 with a constant one. Without it every key
//!   is on/off. The ATmega16 firmware builds without it.
//! - `wind` (default): a fingered group ([`wind`]): a wind robot's fingers and valve, one
//!   note at a time, the valve never open while a finger moves. 252 bytes of RAM with a
//!   configuration in RAM, 40 with a constant one. The ATmega16 firmware builds without it.
//! - `strike` (default): strike groups beside or instead of the keyboard (drums, mallets:
//!   [`strike`]), pulses that end by themselves, leads (an open hi-hat's lift) and dampers. 3260
//!   bytes of RAM with a configuration in RAM, 20 with a constant one. The ATmega16 firmware builds without it.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bits;
mod config;
mod decoder;
pub mod dynamics;
mod fingers;
mod frame;
mod held;
mod interpreter;
mod keymap;
mod message;
mod outcome;
mod output;
mod recording;
mod stats;
#[cfg(feature = "strike")]
pub mod strike;
mod time;
mod values;
#[cfg(feature = "wind")]
pub mod wind;

pub use config::{
    Config, ConfigError, ConfigSource, DutyLimit, GuardConfig, Overlap, Thesis, MAX_LIMIT,
};
pub use decoder::{Counters, Decoded, Decoder};
pub use dynamics::{Duty, Dynamics, DynamicsError, Touch};
pub use frame::{FingerFrame, FlushError};
pub use held::{HeldNotes, NotePool, NoteTable};
pub use interpreter::{Interpreter, KeyPhase, ACTIVE_SENSING_TIMEOUT};
pub use keymap::{BoardSpan, Finger, KeyOf, KeyRange, Layout, OutOfRange};
pub use message::Message;
pub use outcome::{DropReason, Landing, NoteEvent, NoteSink};
pub use output::{full_or_off, on_off, BoardId, BoardKind, FingerBoards};
pub use recording::{Nack, Recording, Write};
pub use stats::Stats;
#[cfg(feature = "strike")]
pub use strike::{Pulse, StrikeError, StrikeGroup, StrikeNotes, Strikes};
pub use time::{Duration, Instant};
pub use values::{Channel, ChannelMask, InvalidValue, Note, Velocity, U14, U7};
#[cfg(feature = "wind")]
pub use wind::{Fingering, Voice, Wind, WindError};
