//! Why a session's part could not start or went wrong: [`StageError`] (a song, a bar, a
//! tempo, a performance), [`SourceError`] (a tempo source) and [`LiveError`] (the live loop).
//!
//! Each says whether the user's input is at fault (`is_bad_input`, a front end's bad-input
//! exit) or something failed while running. The messages say what is wrong without naming a
//! command-line option: the front end adds that (`--from 9: the song has bars 1 to 8`).

use std::fmt;

use orch_perform::PerformError;
use orch_seq::SeqError;

/// Why a song could not be loaded, set up or played.
#[derive(Debug)]
pub enum StageError {
    /// The user's input cannot be used, said in words (a file that is not a Standard MIDI
    /// File, an empty or too large one).
    BadInput(String),
    /// A file that cannot be read.
    Read {
        /// The file, as the user named it.
        name: String,
        /// Why.
        source: std::io::Error,
    },
    /// A Standard MIDI File that cannot be played.
    Song {
        /// The file, as the user named it.
        name: String,
        /// Why.
        source: SeqError,
    },
    /// A bar the song does not have.
    NoSuchBar {
        /// The bar asked for.
        bar: u32,
        /// The song's last bar.
        last: u32,
    },
    /// A tempo factor outside [`orch_perform::follow::FACTOR_RANGE`].
    Tempo(f64),
    /// A performance failed while playing (said as the performer says it).
    Perform(PerformError),
}

impl StageError {
    /// Whether the user's input is at fault (everything but a failed performance).
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, StageError::Perform(_))
    }
}

impl fmt::Display for StageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StageError::BadInput(m) => f.write_str(m),
            StageError::Read { name, .. } => write!(f, "cannot read {name}"),
            StageError::Song { name, .. } => write!(f, "{name} is not a playable MIDI file"),
            StageError::NoSuchBar { last, .. } => write!(f, "the song has bars 1 to {last}"),
            StageError::Tempo(_) => {
                let (low, high) = orch_perform::follow::FACTOR_RANGE;
                write!(f, "give a factor from {low} to {high}, such as 0.5 or 1.25")
            }
            StageError::Perform(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for StageError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            StageError::Read { source, .. } => Some(source),
            StageError::Song { source, .. } => Some(source),
            // Said as the performer says it: its own cause follows.
            StageError::Perform(e) => e.source(),
            _ => None,
        }
    }
}

impl From<PerformError> for StageError {
    fn from(e: PerformError) -> Self {
        StageError::Perform(e)
    }
}

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

impl fmt::Display for SourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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

impl LiveError {
    /// Whether the user's input is at fault ([`LiveError::BadInput`]).
    pub fn is_bad_input(&self) -> bool {
        matches!(self, LiveError::BadInput(_))
    }
}

impl fmt::Display for LiveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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
