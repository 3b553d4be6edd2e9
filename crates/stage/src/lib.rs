//! # orch-stage: one live session of orch
//!
//! What every front end of orch drives and watches while a robot plays live: the terminal
//! (`orch play`, `orch conduct`, `orch run`), and later a daemon or a web page. The front end
//! parses its arguments and draws; the session's parts live here.
//!
//! So far:
//!
//! - [`sources`]: the conductor's tempo sources (a baton video or camera, tap tempo, MIDI
//!   clock from a byte stream or UDP, OSC over UDP), parsed from a `--source` text
//!   ([`sources::SourceSpec`]), opened ([`sources::open_source`]) and followed
//!   ([`sources::follow`]: each cue to the follower, its answer to the performance's
//!   `Control`, and the follower woken between cues when it asks), with what the conductor
//!   did ([`sources::Status`]).
//!
//! - [`live`]: the live interpreter loop ([`LiveRobot`]): live MIDI bytes in, orch-core's
//!   interpreter and guard, finger boards out (the virtual robot, or boards on a Linux I2C
//!   bus), the stream passed on ([`thru`], re-framed by [`framer`]), a robot read again
//!   swapped in when every key is up; every board write shown to whoever watches
//!   ([`BoardWrite`]).
//!
//! - [`session`]: a song played live on one or more robots ([`session::Session`]: a sender
//!   thread a robot, one clock, one `Control` for stop, pause, jump, tempo and a conductor),
//!   a [`session::Snapshot`] of where it stands for any front end, every robot's report and
//!   note-by-note account at the end.
//!
//! Errors are [`SourceError`] (a tempo source: bad input, named, or the I/O failure behind
//! it) and [`LiveError`] (the live loop).
//!
//! ## Cargo features
//!
//! - `camera` (off by default): a live camera (V4L2) as a tempo source, through `orch-baton`'s
//!   own `camera` feature (building it needs libclang). Without it a camera source is refused,
//!   saying how to build with it.

pub mod framer;
pub mod live;
pub mod session;
pub mod sources;
pub mod thru;

pub use live::{BoardWrite, LiveBoards, LiveRobot, ReloadRefused, Totals};

/// Why a live session's part could not start.
#[derive(Debug)]
pub enum SourceError {
    /// Bad input from the user: a source that cannot be opened or read, said in words (the
    /// front end's bad-input exit).
    BadInput(String),
    /// An I/O failure while opening it.
    Io {
        /// What was being done.
        what: String,
        /// The failure.
        source: std::io::Error,
    },
}

impl std::fmt::Display for SourceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SourceError::BadInput(m) => f.write_str(m),
            SourceError::Io { what, .. } => f.write_str(what),
        }
    }
}

impl std::error::Error for SourceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SourceError::Io { source, .. } => Some(source),
            SourceError::BadInput(_) => None,
        }
    }
}

/// What stops a live robot, or keeps it from starting.
#[derive(Debug)]
pub enum LiveError {
    /// Bad input from the user, said in words (the front end's bad-input exit): an output
    /// that cannot be used this way.
    BadInput(String),
    /// The robot's configuration cannot run.
    Robot(orch_robot::RobotError),
    /// An output could not be opened.
    Output(orch_io::OutError),
    /// Something failed while running: a board write, a thru output.
    Failed(String),
}

impl std::fmt::Display for LiveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LiveError::BadInput(m) | LiveError::Failed(m) => f.write_str(m),
            LiveError::Robot(e) => write!(f, "{e}"),
            LiveError::Output(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for LiveError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            LiveError::Robot(e) => Some(e),
            LiveError::Output(e) => Some(e),
            _ => None,
        }
    }
}

impl From<orch_robot::RobotError> for LiveError {
    fn from(e: orch_robot::RobotError) -> Self {
        LiveError::Robot(e)
    }
}

impl From<orch_io::OutError> for LiveError {
    fn from(e: orch_io::OutError) -> Self {
        LiveError::Output(e)
    }
}
