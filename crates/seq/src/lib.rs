//! # orch-seq: the Standard MIDI File sequencer
//!
//! Reads a Standard MIDI File, works out when every message plays, and sends it to the robot
//! early enough that each key sounds on time.
//!
//! - [`Song`] ([`Song::parse`]): formats 0, 1 and 2, the tempo map and SMPTE division, every
//!   track merged in playing order into [`Event`]s with exact µs times; damaged files are a
//!   [`SeqError`], never a panic. Built on [`midly`].
//! - [`wire`]: timed messages as the bytes a sequencer sends, optionally with running status.
//! - [`Clock`]: [`VirtualClock`] (as fast as possible, deterministic) and [`RealClock`]
//!   (sleeps, then spins to the deadline; keeps [`Lateness`] statistics).
//! - [`schedule`]: tempo scale ([`TempoScale`]) and latency compensation ([`Compensation`]):
//!   presses and releases sent early by each key's mechanical delays, never reordered per
//!   key, never closer than the re-strike gap.
//!
//! ```
//! use orch_seq::{schedule, Compensation, RunningStatus, Song, TempoScale, VirtualClock};
//!
//! // A one-track file: middle C for a quarter note at 120 bpm (480 ticks per quarter).
//! let smf = [
//!     b'M', b'T', b'h', b'd', 0, 0, 0, 6, 0, 0, 0, 1, 0x01, 0xE0,
//!     b'M', b'T', b'r', b'k', 0, 0, 0, 12,
//!     0x00, 0x90, 60, 100, // note on at tick 0
//!     0x83, 0x60, 60, 0,   // velocity 0 at tick 480
//!     0x00, 0xFF, 0x2F, 0x00,
//! ];
//! let song = Song::parse(&smf).unwrap();
//! assert_eq!(song.notes(), 1);
//! assert_eq!(song.events()[1].time_us, 500_000);
//!
//! // The robot strikes 20 ms and releases 30 ms after being told to.
//! let comp = Compensation::uniform(|_channel, note| Some(u16::from(note)), 20_000, 30_000);
//! let plan = schedule(song.events(), TempoScale::NORMAL, Some(&comp));
//! assert_eq!(plan.lead_in_us(), 20_000);
//! assert_eq!(plan.entries()[1].send_us, 490_000); // 520 ms on the clock − 30 ms
//!
//! let mut sent = Vec::new();
//! plan.play(&mut VirtualClock::new(), RunningStatus::On, |t, bytes| sent.push((t, bytes.to_vec())));
//! assert_eq!(sent[1], (490_000, vec![60, 0]));
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod clock;
mod error;
mod schedule;
mod smf;
mod song;
mod stream;

pub use clock::{Clock, Lateness, RealClock, VirtualClock};
pub use error::SeqError;
pub use midly;
pub use schedule::{schedule, Compensation, Schedule, ScheduleStats, Scheduled, TempoScale};
pub use song::{Event, Song, TempoChange, TimeSignature, WireBytes, DEFAULT_TEMPO};
pub use stream::{wire, RunningStatus, Wire};
