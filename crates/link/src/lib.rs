//! Robots on several hosts in phase: an orch performance steered by an
//! [Ableton Link](https://ableton.github.io/link) session.
//!
//! Link is how music software and hardware share tempo, beat and phase on a LAN: peers find
//! each other by multicast, with no server, and any of them may change the tempo or start
//! and stop. An orch robot joins as one more peer. A score quarter note is one session beat;
//! every robot comes in on one bar line ([`entry()`]); each look at the session
//! ([`Steer::step`]) keeps the performance on the beat, through the file's own tempo map;
//! the session stopping stops the robot, every key up. A performance that follows a
//! conductor can lead the session instead ([`Lead`]): robots on other hosts then follow the
//! one conductor.
//!
//! This crate's own code is pure: it reads a [`Timeline`] (the session as one host sees it)
//! and says what the performance must do. The session itself is the `abl` feature's
//! [`session`] module, on Ableton's own Link SDK through `rusty_link`: that code is
//! GPL-2.0-or-later, so a binary built with the feature is distributed under the GPL.
//!
//! ```
//! use orch_link::{entry, Line, Steer, Step};
//! use orch_perform::{ScoreBeats, TimeMap};
//!
//! // A session at 120 BPM that began to play at host time 1 s, on beat 8.
//! let session = Line { bpm: 120.0, at_us: 1_000_000, beat: 8.0, playing: true, started_beat: 8.0 };
//! // A robot that needs 100 ms comes in at bar one: beat 12, host time 3 s.
//! let entry = entry(&session, 4.0, 1_000_000, 100_000);
//! assert_eq!((entry.quarter, entry.host_us), (0, 3_000_000));
//! // A score at 60 BPM (quarters of 1 s) plays twice as fast to keep the session's beat.
//! let beats = ScoreBeats::from_times((0..64).map(|q| q * 1_000_000).collect());
//! let steer = Steer::new(beats, 4.0, entry, 100_000);
//! assert_eq!(steer.factor_at(0, session.bpm).unwrap().get(), 2.0);
//! // Started on time at that factor (host and wall time alike here), it is left alone.
//! let map = TimeMap::new(3_000_000, steer.factor_at(0, 120.0).unwrap());
//! assert_eq!(steer.step(&session, 4_000_000, 4_000_000, &map), Step::Hold);
//! ```

#![forbid(unsafe_code)]

pub mod announce;
pub mod entry;
pub mod guard;
pub mod lead;
#[cfg(feature = "abl")]
pub mod session;
pub mod steer;
pub mod timeline;

pub use announce::{Anchor, REANCHOR_US};
pub use entry::{bar_one, entry, Entry, LEAD_IN_BEATS};
pub use guard::{StopGuard, Watch, GUARD_MAX_US, GUARD_US};
pub use lead::{bar_line_after, Lead, Publish, LEAD_IN_MARGIN};
pub use steer::{Steer, Step, HORIZON_US, JUMP_QUARTERS, SLACK};
pub use timeline::{Line, Timeline};
