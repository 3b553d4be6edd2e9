//! What a roll is drawn from: plain data, with no tie to the performer (a web page can fill it
//! from the note-by-note account's JSON just as well).

/// What became of a note: the account's outcomes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Its own strike sounded within 1 ms of its score time.
    OnTime,
    /// Its own strike sounded later than that.
    Late,
    /// Its own strike sounded more than 1 ms early.
    Early,
    /// Struck together with another note on the same key at the same score time.
    Unison,
    /// Its key was already down for another note: no strike of its own.
    Joined,
    /// Not played, with the reason (`channel`, `range`, `power`, `too_fast`, `too_soft`,
    /// `cancelled`, `stopped`).
    Dropped(String),
    /// It struck, but made no sound.
    Unmatched,
    /// The performance jumped past it.
    Skipped,
}

impl Outcome {
    /// Every outcome's word, in the legend's order.
    pub const NAMES: [&'static str; 8] = [
        "on_time",
        "late",
        "early",
        "unison",
        "joined",
        "dropped",
        "unmatched",
        "skipped",
    ];

    /// The outcome of the account's words (`outcome`, and `reason` for a drop); `None` for a
    /// word it does not know.
    pub fn from_account(outcome: &str, reason: Option<&str>) -> Option<Self> {
        Some(match outcome {
            "on_time" => Self::OnTime,
            "late" => Self::Late,
            "early" => Self::Early,
            "unison" => Self::Unison,
            "joined" => Self::Joined,
            "dropped" => Self::Dropped(reason.unwrap_or("unknown").to_string()),
            "unmatched" => Self::Unmatched,
            "skipped" => Self::Skipped,
            _ => return None,
        })
    }

    /// Its word in the account (and in the drawing's classes).
    pub fn name(&self) -> &'static str {
        match self {
            Self::OnTime => "on_time",
            Self::Late => "late",
            Self::Early => "early",
            Self::Unison => "unison",
            Self::Joined => "joined",
            Self::Dropped(_) => "dropped",
            Self::Unmatched => "unmatched",
            Self::Skipped => "skipped",
        }
    }

    /// The drop's reason.
    pub fn reason(&self) -> Option<&str> {
        match self {
            Self::Dropped(r) => Some(r),
            _ => None,
        }
    }
}

/// The robot's own strike of a note: from when it sounded to when its key was fully up again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strike {
    /// When it sounded, ms from the start.
    pub sounded_ms: f64,
    /// When its key was up again, ms (at least `sounded_ms`).
    pub up_ms: f64,
    /// Sounded − score, ms (positive: late).
    pub onset_ms: f64,
    /// How loud it sounded on the MIDI velocity scale (127 on an on/off key).
    pub velocity: Option<u8>,
}

/// One note of the score and what became of it.
#[derive(Clone, Debug, PartialEq)]
pub struct RollNote {
    /// When the score wants it, ms from the start.
    pub t_ms: f64,
    /// When the score lets it go (its Note-Off), ms.
    pub end_ms: f64,
    /// Its bar and beat (from 1).
    pub bar: u32,
    /// Its beat in the bar.
    pub beat: u32,
    /// The MIDI note as written (C4 = 60).
    pub note: u8,
    /// Its channel, 1..=16.
    pub channel: u8,
    /// Its velocity in the file.
    pub velocity: u8,
    /// The MIDI note of the key it landed on (a folded note lands octaves away), if any.
    pub landed: Option<u8>,
    /// What became of it.
    pub outcome: Outcome,
    /// Its own strike, if it had one that sounded.
    pub strike: Option<Strike>,
    /// The named lane it is drawn on (a drum of a kit: [`Roll::lanes`]), instead of its
    /// pitch's row.
    pub lane: Option<u16>,
    /// Struck, not held (a drum, a bar): its outline is a hit at its start, whatever its
    /// Note-Off says.
    pub hit: bool,
}

/// A bar line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarLine {
    /// The bar's number, from 1.
    pub bar: u32,
    /// Where it begins, ms from the start.
    pub t_ms: f64,
}

/// Everything a roll shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Roll {
    /// A line of text above the drawing (the file's name).
    pub title: String,
    /// Every note, in score order.
    pub notes: Vec<RollNote>,
    /// The bar lines, in order.
    pub bars: Vec<BarLine>,
    /// Where the drawing ends, ms (the song's end, or a later key-up).
    pub end_ms: f64,
    /// The robot's lowest and highest key, as MIDI notes (36..=96 on the thesis's robot).
    /// `None` for a robot with no keys or bars (a drum kit alone).
    pub keys: Option<(u8, u8)>,
    /// Whether the robot plays velocity (PWM boards): then each strike's loudness is drawn.
    pub dynamics: bool,
    /// Named lanes below the pitch rows, top to bottom: a drum kit's drums (kick, snare…).
    pub lanes: Vec<String>,
    /// Whether the drawing has pitch rows: false when every note is on a lane (a drum kit
    /// alone).
    pub pitched: bool,
}
