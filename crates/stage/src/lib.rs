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
//!   `Control`), with what the conductor did ([`sources::Status`]).
//!
//! Errors are [`SourceError`]: bad input (a source that cannot be opened, named) or the I/O
//! failure behind it.
//!
//! ## Cargo features
//!
//! - `camera` (off by default): a live camera (V4L2) as a tempo source, through `orch-baton`'s
//!   own `camera` feature (building it needs libclang). Without it a camera source is refused,
//!   saying how to build with it.

pub mod sources;

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
