//! What can go wrong while rendering, and which of it is the user's input.

use std::fmt;
use std::path::PathBuf;

use crate::soundfont::SEARCHED;

/// A failure of [`crate`]'s rendering: a soundfont not found or not readable, a performance
/// that did not keep its sounds, the synthesizer refusing its settings, the WAV file.
#[derive(Debug)]
pub enum RenderError {
    /// No soundfont was given and none is installed where Debian's packages put them.
    NoSoundFont,
    /// The soundfont given does not exist.
    SoundFontMissing(PathBuf),
    /// The soundfont could not be read (permissions, a folder, an I/O error).
    SoundFontUnreadable {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not a SoundFont 2 the synthesizer can use.
    SoundFontInvalid {
        /// The file.
        path: PathBuf,
        /// The synthesizer's words.
        message: String,
    },
    /// The performance was recorded without its sound events (`orch_sim::Keep::Presses`
    /// forgets them): render from one recorded with `Keep::Everything`.
    SoundsNotKept,
    /// The performance's key-down sounds and its sounding presses do not pair up (a
    /// performance put together by hand, or a bug in the virtual robot).
    Inconsistent(String),
    /// The synthesizer refused its settings (a sample rate outside 16 000..=192 000 Hz).
    Synth(String),
    /// Writing the WAV file failed.
    Wav {
        /// The file.
        path: PathBuf,
        /// Why.
        source: hound::Error,
    },
    /// The sink the samples went to failed.
    Sink(String),
}

impl RenderError {
    /// Whether this is the user's input at fault (a soundfont or a setting), not a failure
    /// while running: a command line exits 2 for these.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Self::NoSoundFont
                | Self::SoundFontMissing(_)
                | Self::SoundFontUnreadable { .. }
                | Self::SoundFontInvalid { .. }
                | Self::Synth(_)
        )
    }
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoSoundFont => {
                write!(
                    f,
                    "no soundfont found: give one with --soundfont FILE.sf2, or install one \
                     (Debian: `apt-get install timgm6mb-soundfont`, 6 MB; or \
                     `fluid-soundfont-gm`, 145 MB); looked for"
                )?;
                for (i, (path, _)) in SEARCHED.iter().enumerate() {
                    let sep = if i == 0 { " " } else { ", " };
                    write!(f, "{sep}{path}")?;
                }
                Ok(())
            }
            Self::SoundFontMissing(p) => write!(
                f,
                "soundfont {}: no such file (Debian's timgm6mb-soundfont installs \
                 /usr/share/sounds/sf2/TimGM6mb.sf2)",
                p.display()
            ),
            Self::SoundFontUnreadable { path, source } => {
                write!(f, "soundfont {}: {source}", path.display())
            }
            Self::SoundFontInvalid { path, message } => write!(
                f,
                "soundfont {}: not a SoundFont 2 file this synthesizer can use: {message}",
                path.display()
            ),
            Self::SoundsNotKept => f.write_str(
                "the performance kept no sound events: record it with orch_sim::Keep::Everything",
            ),
            Self::Inconsistent(what) => write!(f, "the performance does not add up: {what}"),
            Self::Synth(message) => write!(f, "the synthesizer refused its settings: {message}"),
            Self::Wav { path, source } => write!(f, "{}: {source}", path.display()),
            Self::Sink(message) => f.write_str(message),
        }
    }
}

impl std::error::Error for RenderError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::SoundFontUnreadable { source, .. } => Some(source),
            Self::Wav { source, .. } => Some(source),
            _ => None,
        }
    }
}
