//! # orch-seq: Standard MIDI Files
//!
//! Reads a Standard MIDI File and works out when every message plays; the performer
//! (`orch-perform`) plans from it when to send each message to a robot.
//!
//! - [`Song`] ([`Song::parse`]): formats 0, 1 and 2, the tempo map and SMPTE division, every
//!   track merged in playing order into [`Event`]s with exact µs times; damaged files are a
//!   [`SeqError`], never a panic. Built on [`midly`].
//! - [`wire`]: timed messages as the bytes a sequencer sends, optionally with running status.
//! - [`Clock`]: [`VirtualClock`] (as fast as possible, deterministic) and [`RealClock`]
//!   (sleeps, then spins to the deadline; keeps [`Lateness`] statistics); a wait that a
//!   [`Bell`] ends early ([`Clock::wait_until_rung`]).
//!
//! ```
//! use orch_seq::{wire, RunningStatus, Song};
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
//! // On a DIN line with running status, the second message goes without its status byte.
//! let sent: Vec<(u64, Vec<u8>)> = wire(song.messages(), RunningStatus::On)
//!     .map(|(t, bytes)| (t, bytes.to_vec()))
//!     .collect();
//! assert_eq!(sent[1], (500_000, vec![60, 0]));
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod bell;
mod clock;
mod error;
mod smf;
mod song;
mod spans;
mod stream;

pub use bell::Bell;
pub use clock::{Clock, Lateness, RealClock, VirtualClock};
pub use error::SeqError;
pub use midly;
pub use song::{Event, Song, TempoChange, TimeSignature, WireBytes, DEFAULT_TEMPO};
pub use spans::NoteSpan;
pub use stream::{wire, RunningStatus, Wire};
