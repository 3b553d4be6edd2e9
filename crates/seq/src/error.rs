//! Why a Standard MIDI File was refused.

use std::fmt;

/// A Standard MIDI File that cannot be played, and why.
///
/// Byte offsets count from the start of the file. Track numbers in messages are 1-based, as
/// people count them; the `track` fields are 0-based indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SeqError {
    /// The file holds no bytes at all.
    Empty,
    /// The file does not start with an `MThd` header chunk (a RIFF `RMID` wrapper is not
    /// unwrapped either).
    NotMidi,
    /// The header chunk is cut short or says something impossible.
    BadHeader(&'static str),
    /// The header names a format other than 0, 1 or 2.
    UnsupportedFormat(u16),
    /// The time division cannot be played: zero ticks per quarter note, an SMPTE frame rate
    /// other than 24, 25, 29.97 or 30, or zero ticks per frame.
    BadDivision(&'static str),
    /// The file ends before all the tracks the header declares.
    MissingTracks {
        /// Tracks the header declares.
        declared: u16,
        /// Tracks found before the end of the file.
        found: u16,
    },
    /// A chunk declares more bytes than the file has left.
    ChunkPastEnd {
        /// Offset of the chunk's 8-byte header.
        offset: usize,
        /// The declared length.
        declared: u32,
        /// Bytes actually left after the chunk header.
        available: usize,
    },
    /// The file ends inside a chunk's 8-byte header.
    ChunkHeaderCut {
        /// Offset of the partial chunk header.
        offset: usize,
    },
    /// An event inside a track is malformed.
    Event {
        /// 0-based track index.
        track: u16,
        /// Offset of the offending byte.
        offset: usize,
        /// What is wrong.
        reason: &'static str,
    },
    /// A Set Tempo meta event says 0 µs per quarter note: time would stand still, and every
    /// later note would sound at the same instant.
    ZeroTempo {
        /// 0-based track index.
        track: u16,
        /// The tick of the event, counted from the start of its track.
        tick: u64,
        /// Offset of the event's first byte (its delta time).
        offset: usize,
    },
}

impl fmt::Display for SeqError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SeqError::Empty => f.write_str("not a MIDI file: the file is empty"),
            SeqError::NotMidi => {
                f.write_str("not a Standard MIDI File: it does not start with an MThd header")
            }
            SeqError::BadHeader(why) => write!(f, "bad MIDI header: {why}"),
            SeqError::UnsupportedFormat(format) => write!(
                f,
                "unsupported MIDI file format {format} (only formats 0, 1 and 2 exist)"
            ),
            SeqError::BadDivision(why) => write!(f, "unplayable time division: {why}"),
            SeqError::MissingTracks { declared, found } => write!(
                f,
                "the header declares {declared} tracks but the file ends after {found}"
            ),
            SeqError::ChunkPastEnd {
                offset,
                declared,
                available,
            } => write!(
                f,
                "the chunk at byte {offset} declares {declared} bytes but only {available} remain \
                 (truncated or damaged file)"
            ),
            SeqError::ChunkHeaderCut { offset } => {
                write!(f, "the file ends inside a chunk header at byte {offset}")
            }
            SeqError::Event {
                track,
                offset,
                reason,
            } => write!(
                f,
                "track {}: {reason} (at byte {offset})",
                u32::from(*track) + 1
            ),
            SeqError::ZeroTempo {
                track,
                tick,
                offset,
            } => write!(
                f,
                "track {}: a Set Tempo of 0 µs per quarter note at tick {tick} (at byte \
                 {offset}); a tempo must be longer than 0, or every later note would sound at \
                 once",
                u32::from(*track) + 1
            ),
        }
    }
}

impl std::error::Error for SeqError {}
