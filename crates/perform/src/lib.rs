//! # orch-perform: the performer
//!
//! One streaming pipeline from a score to a robot, with an honest account of every note.
//! Every front end that plays a score (`orch play`, `orch analyze`, `orch conduct`; later a
//! daemon or a web page) uses it.
//!
//! - **Source**: score events in order ([`ScoreEvent`]), from a song ([`song_events`]).
//! - **Planner** ([`Planner`], [`plan`]): plans in score time with a bounded lookahead;
//!   sends each key's press early by its mechanical delay and each release early where a
//!   re-strike needs its rest; reasons about notes, not only keys; the tempo can change at
//!   any moment ([`TimeMap`], [`Control::set_tempo`]).
//! - **Robot side**: a local robot ([`LocalRobot`]: `orch-core`'s interpreter and any
//!   finger boards; [`SimBoards`] is the virtual robot behind `orch-boards`' real driver), or
//!   a MIDI byte output ([`MidiOut`]) for a robot that interprets MIDI itself, with the
//!   virtual robot as its copy at the far end of the [`Link`] (a DIN line takes 320 µs a
//!   byte, and compensation counts it).
//! - **The account** ([`Ledger`], [`Outcome`], [`Report`]): the interpreter says whether
//!   each note struck, joined or was dropped and why; the virtual robot says when each strike
//!   sounded. Every note gets exactly one outcome; they add up.
//! - **A conductor** ([`conduct`]): tempo sources behind one trait ([`TempoSource`]: MIDI
//!   clock, OSC, tap tempo, the baton tracker through the front end) and the [`Follower`]
//!   ([`follow`]) that turns their beats into tempo changes, following the rate or also the
//!   phase, by one rule for every source ([`meter`]: a sustained change taken at its second
//!   beat, a single odd interval never).
//! - **Real time** ([`realtime`]): the sender on its own thread at real-time priority where
//!   the OS allows it, with a precise sleep, lateness measured per message sent.
//!
//! ```
//! use orch_perform::{song_events, Performer, Setup};
//! use orch_seq::Song;
//!
//! // Middle C for a quarter note at 120 bpm.
//! let smf = [
//!     b'M', b'T', b'h', b'd', 0, 0, 0, 6, 0, 0, 0, 1, 0x01, 0xE0,
//!     b'M', b'T', b'r', b'k', 0, 0, 0, 12,
//!     0x00, 0x90, 60, 100, 0x83, 0x60, 60, 0, 0x00, 0xFF, 0x2F, 0x00,
//! ];
//! let song = Song::parse(&smf).unwrap();
//! // The thesis's robot, compensated, at the written tempo (`Setup::for_robot` reads yours).
//! let setup = Setup::thesis();
//! // On the virtual clock, as fast as the machine goes; `.clock(..)` paces it in real time,
//! // `.midi(..)` sends the bytes to a robot, `.control(..)` and `.live(..)` steer and watch.
//! let played = Performer::new(&setup, song_events(&song), song.notes()).run().unwrap();
//! let report = played.report(None);
//! assert_eq!(report.outcomes.on_time, 1);
//! assert!(report.adds_up());
//! ```
//!
//! The same to a MIDI output, steered from another thread and watched:
//!
//! ```
//! use orch_perform::{Control, Live, MidiRecording, Performer, ScoreEvent, Setup};
//!
//! let setup = Setup::thesis();
//! let events = [(0, [0x90, 60, 100]), (500_000, [0x80, 60, 0])].map(|(t, m)| ScoreEvent {
//!     score_us: t,
//!     bytes: orch_seq::WireBytes::new(&m),
//! });
//! let control = Control::new();
//! let mut out = MidiRecording::default();
//! let mut views = 0;
//! let mut live = |_: &Live| views += 1;
//! let played = Performer::new(&setup, events.into_iter(), 1)
//!     .control(&control)
//!     .midi(&mut out)
//!     .live(&mut live)
//!     .run()
//!     .unwrap();
//! assert!(played.report(None).adds_up());
//! assert!(out.sent.iter().any(|(_, m)| m == &[0x90, 60, 100]));
//! assert!(views > 0);
//! ```
//!
//! ## Cargo features
//!
//! None.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod account;
pub mod conduct;
pub mod control;
pub mod follow;
pub mod ledger;
pub mod link;
pub mod meter;
pub mod performer;
pub mod plan;
pub mod played;
pub mod realtime;
pub mod report;
pub mod robot;
mod run;
pub mod setup;
pub mod tempo;
pub mod time;

pub use account::NoteLine;
pub use conduct::{
    Action, ConductError, Cue, MidiClock, OscCues, ScoreBeats, TapTempo, TempoSource, Timed,
};
pub use control::Control;
pub use follow::{Follow, Follower};
pub use ledger::{Ledger, NoteRecord, Outcome, ON_TIME_US};
pub use link::{DinWire, Link, MidiOut, MidiRecording, RunningStatus};
pub use meter::{Heard, Meter};
pub use performer::{Live, PerformError, Performer, KEEP_ALIVE_US};
pub use plan::{
    Jumped, KeyMap, NoteId, PlanRules, PlanStats, Planned, Planner, ScoreEvent, Skipped,
};
pub use played::{Played, VELOCITY_TOLERANCE};
pub use report::{Bus, Dropped, GroupReport, Outcomes, Planning, Report, Spread, VelocityError};
pub use robot::{
    sim_boards, Boards, Decided, HostInterpreter, LocalRobot, RobotError, SimBoards, MAX_BOARDS,
    MAX_KEYS,
};
pub use setup::Setup;
pub use tempo::{Tempo, TimeMap};
pub use time::{ScoreTime, WallTime};

/// The score events of a song, in order.
pub fn song_events(song: &orch_seq::Song) -> impl Iterator<Item = ScoreEvent> + Clone + '_ {
    song.events().iter().map(|e| ScoreEvent {
        score_us: e.time_us,
        bytes: e.bytes.clone(),
    })
}

/// The thesis's robot with orch's guard, for a host ([`MAX_BOARDS`] boards of room).
pub fn thesis_config() -> orch_core::Config<MAX_BOARDS> {
    let t = orch_core::Config::THESIS;
    let mut boards = [orch_core::BoardSpan {
        address: 0,
        keys: 0,
        first_bit: 0,
    }; MAX_BOARDS];
    boards[..4].copy_from_slice(&t.layout.boards);
    orch_core::Config {
        channels: t.channels,
        range: t.range,
        out_of_range: t.out_of_range,
        layout: orch_core::Layout { boards },
        sustain: t.sustain,
        overlap: t.overlap,
        guard: t.guard,
        dynamics: t.dynamics,
        strikes: t.strikes,
        wind: t.wind,
    }
}
