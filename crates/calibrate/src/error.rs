//! Why a score cannot be made or a recording cannot be used.

use std::fmt;

/// What went wrong. Every variant but [`Internal`](Self::Internal) is the user's input: a
/// recording that cannot calibrate anything gets one of these, and no robot.toml.
#[derive(Debug)]
pub enum CalibrateError {
    /// `--levels` out of 1..=127.
    Levels(u32),
    /// The file is not a WAV file (or not a readable one).
    NotWav(String),
    /// A WAV file in a sample format or rate this reader does not take.
    Format(String),
    /// The recording is shorter than the score it should hold.
    TooShort {
        /// The recording's length, s.
        recording_s: f64,
        /// What it needs, s.
        needed_s: f64,
    },
    /// Nothing louder than the given level, dBFS.
    Silent {
        /// The loudest sample, dBFS.
        peak_dbfs: f64,
    },
    /// Most of the recording is clipped.
    Clipped {
        /// The share of sounding seconds with clipped samples, 0..=1.
        share: f64,
    },
    /// The opening sync figure is not in the recording: another score, or not the robot.
    SyncNotFound {
        /// The most figure strikes found together anywhere.
        best: usize,
        /// How many the figure has.
        of: usize,
    },
    /// The sync figure was heard but no key's strikes were.
    NothingHeard,
    /// `--anchor NOTE=MS` names a key that is not the robot's or did not sound.
    Anchor(String),
    /// A bug: the calibrated robot.toml did not load.
    Internal(String),
}

impl fmt::Display for CalibrateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Levels(n) => write!(f, "--levels {n}: give 1 to 127 velocity levels"),
            Self::NotWav(why) => write!(f, "not a WAV file ({why})"),
            Self::Format(why) => write!(f, "a WAV file this cannot read: {why}"),
            Self::TooShort {
                recording_s,
                needed_s,
            } => write!(
                f,
                "the recording is too short for the calibration score: {recording_s:.1} s, the \
                 score needs {needed_s:.1} s from its sync figure on (record from before the \
                 first strike to after the last)"
            ),
            Self::Silent { peak_dbfs } => write!(
                f,
                "the recording is silent (its loudest sample is {peak_dbfs:.1} dBFS): is the \
                 microphone connected and its level up?"
            ),
            Self::Clipped { share } => write!(
                f,
                "the recording is clipped through most of it ({:.0} % of its sounding seconds \
                 hit full scale): lower the microphone's gain and record again",
                share * 100.0
            ),
            Self::SyncNotFound { best, of } => write!(
                f,
                "the calibration score's sync figure is not in the recording (at best {best} of \
                 its {of} strikes in their rhythm): a recording of another score, or the robot \
                 did not play it (write the score with `orch calibrate --score`, and give the \
                 same --levels)"
            ),
            Self::NothingHeard => f.write_str(
                "the sync figure is there but no key's strikes are: was the score played with \
                 the same --levels?",
            ),
            Self::Anchor(why) => write!(f, "--anchor: {why}"),
            Self::Internal(why) => write!(f, "internal error: {why}"),
        }
    }
}

impl std::error::Error for CalibrateError {}

impl CalibrateError {
    /// Whether the error is the user's input (everything but a bug).
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, Self::Internal(_))
    }
}
