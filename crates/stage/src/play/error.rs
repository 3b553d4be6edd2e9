//! Why a [`Play`](super::Play) could not start, or failed: each variant says which part of
//! what the front end asked for was at fault, so it can name its own option
//! (`--from 9: the song has bars 1 to 8`).

use std::convert::Infallible;
use std::fmt;
use std::path::PathBuf;

use orch_robot::RobotError;

use crate::watch::WatchError;
use crate::{LiveError, StageError};

/// A file a play writes when it has ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leaves {
    /// The note-by-note account (`--notes`).
    Notes,
    /// Every board write (`--writes`).
    Writes,
}

/// Why a play could not start or failed; `E` is the watcher's own error.
#[derive(Debug)]
pub enum PlayError<E = Infallible> {
    /// The song could not be loaded.
    Song(StageError),
    /// The song has no such bar to start from.
    From {
        /// The bar asked for.
        bar: u32,
        /// Why not.
        error: StageError,
    },
    /// The robot's configuration was refused.
    Robot(RobotError),
    /// A tempo factor out of range.
    Tempo {
        /// The factor asked for.
        factor: f64,
        /// Why not.
        error: StageError,
    },
    /// A file to leave could not be created or written.
    File {
        /// Which.
        leaves: Leaves,
        /// Where.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
        /// Whether it failed at its creation, before anything played.
        created: bool,
    },
    /// An output is not one, or could not be opened.
    Out(LiveError),
    /// On the virtual clock only the virtual robot plays: an output named.
    FastOut(String),
    /// The performance on the virtual clock failed.
    Fast(StageError),
    /// The live performance failed (the watcher, a robot, a panic).
    Live {
        /// Whether the OS refused real-time priority to a sender.
        priority_refused: bool,
        /// Why.
        error: WatchError<E>,
    },
}

impl<E> PlayError<E> {
    /// Whether the user's input is at fault (everything before anything played).
    pub fn is_bad_input(&self) -> bool {
        match self {
            PlayError::Song(e) | PlayError::From { error: e, .. } => e.is_bad_input(),
            PlayError::Tempo { error: e, .. } => e.is_bad_input(),
            PlayError::Robot(_) | PlayError::FastOut(_) => true,
            PlayError::File { created, .. } => *created,
            PlayError::Out(e) => e.is_bad_input(),
            PlayError::Fast(_) | PlayError::Live { .. } => false,
        }
    }
}

impl<E: fmt::Debug> fmt::Display for PlayError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlayError::Song(e) | PlayError::Fast(e) => write!(f, "{e}"),
            PlayError::From { bar, error } => write!(f, "bar {bar}: {error}"),
            PlayError::Robot(e) => write!(f, "{e}"),
            PlayError::Tempo { factor, error } => write!(f, "tempo {factor}: {error}"),
            PlayError::File { path, source, .. } => write!(f, "{}: {source}", path.display()),
            PlayError::Out(e) => write!(f, "{e}"),
            PlayError::FastOut(out) => write!(
                f,
                "on the virtual clock only the virtual robot plays, not {out}"
            ),
            PlayError::Live { error, .. } => match error {
                WatchError::Front(e) => write!(f, "the watcher failed: {e:?}"),
                WatchError::Panicked(_) => f.write_str("the watcher panicked"),
                WatchError::Failed(spec, why) => write!(f, "{}: {why}", spec.text),
            },
        }
    }
}

impl<E: fmt::Debug> std::error::Error for PlayError<E> {}
