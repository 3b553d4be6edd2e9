//! The performer: the planner's sends, paced by a clock, to the robot; the account at the end.
//!
//! [`Performer`] is told once what it plays and how, then [`run`](Performer::run)s:
//!
//! ```
//! # use orch_perform::{Performer, Setup, ScoreEvent};
//! # let setup = Setup::thesis();
//! let played = Performer::new(&setup, std::iter::empty::<ScoreEvent>(), 0).run().unwrap();
//! assert!(played.records.is_empty());
//! ```

use orch_core::Stats;
use orch_seq::Clock;

use crate::control::Control;
use crate::link::MidiOut;
use crate::plan::ScoreEvent;
use crate::played::Played;
use crate::run::{Run, SendMidi};
use crate::setup::Setup;

/// The longest the performer leaves a line silent: it sends Active Sensing (0xFE) after
/// 200 ms without a byte, so the robot's watchdog fires only when the sender is really gone.
pub const KEEP_ALIVE_US: u64 = 200_000;

/// A performance to run: what it plays (`source`: score events in order, `notes` Note-Ons in
/// all), as `setup` says, and how ([`clock`](Self::clock), [`midi`](Self::midi),
/// [`control`](Self::control), [`live`](Self::live)).
///
/// Without a MIDI output the virtual robot is the robot; with one the bytes go out there,
/// and the virtual robot is its copy at the far end of `setup.link`.
///
/// After a jump the account goes on as one: notes a jump passes over (after a jump forward,
/// those between the place it left and the target; those the performer had read ahead and
/// not sent yet) are [`Outcome::Skipped`](crate::Outcome::Skipped); after a jump back, the
/// notes played again are records of their own ([`Played::replayed`]).
pub struct Performer<'a, S> {
    pub(crate) setup: &'a Setup,
    pub(crate) source: S,
    pub(crate) notes: usize,
    pub(crate) clock: Option<&'a mut dyn Clock>,
    pub(crate) control: Option<&'a Control>,
    pub(crate) midi: Option<&'a mut dyn SendMidi>,
    pub(crate) live: Option<&'a mut dyn FnMut(&Live)>,
}

impl<'a, S> Performer<'a, S>
where
    S: Iterator<Item = ScoreEvent> + Clone,
{
    /// `source` (score events in order, `notes` Note-Ons in all) as `setup` says: on the
    /// virtual robot alone, on a virtual clock (as fast as the machine goes), unsteered.
    pub fn new(setup: &'a Setup, source: S, notes: usize) -> Self {
        Self {
            setup,
            source,
            notes,
            clock: None,
            control: None,
            midi: None,
            live: None,
        }
    }

    /// Paces the sends by `clock` (a real clock plays in real time), and measures each send's
    /// lateness on it ([`Played::lateness_us`]).
    pub fn clock(mut self, clock: &'a mut dyn Clock) -> Self {
        self.clock = Some(clock);
        self
    }

    /// Steered by `control`: a request wakes the performance at once (its
    /// [`Bell`](orch_seq::Bell)). `source` is then cloned before it is read, so a jump
    /// ([`Control::jump_to`]) can read the score again from its start.
    pub fn control(mut self, control: &'a Control) -> Self {
        self.control = Some(control);
        self
    }

    /// Sends the bytes to `out` (a robot that interprets MIDI itself), the virtual robot
    /// being its copy at the far end of the setup's link.
    pub fn midi<M: MidiOut + 'a>(mut self, out: &'a mut M) -> Self {
        self.midi = Some(out);
        self
    }

    /// Calls `live` with where the performance stands, at least every 40 ms (or as
    /// [`Control::poll_every`] says).
    pub fn live(mut self, live: &'a mut dyn FnMut(&Live)) -> Self {
        self.live = Some(live);
        self
    }

    /// Plays it to the end (or until stopped), then accounts for every note.
    pub fn run(self) -> Result<Played, PerformError> {
        Run::start(self)?.play()
    }
}

/// Where a performance stands, for a live view.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Live {
    /// Where the song is, µs of score time.
    pub song_us: u64,
    /// Whether each key of the virtual robot is down.
    pub keys_down: Vec<bool>,
    /// Score notes sent so far.
    pub notes_sent: u64,
    /// The tempo factor.
    pub tempo: f64,
    /// Paused ([`Control::pause`](crate::Control::pause)).
    pub paused: bool,
    /// The interpreter's counters so far (the guard's among them: keys cut by the hold
    /// limit, the duty limit and the watchdog, notes refused by the power budget).
    pub stats: Stats,
}

/// What went wrong in a performance.
#[derive(Debug)]
pub enum PerformError {
    /// The robot's configuration cannot run, or the virtual robot failed.
    Robot(String),
    /// The MIDI output failed.
    Midi(Box<dyn std::error::Error + Send + Sync>),
}

impl std::fmt::Display for PerformError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PerformError::Robot(e) => write!(f, "the robot: {e}"),
            PerformError::Midi(e) => write!(f, "the MIDI output: {e}"),
        }
    }
}

impl std::error::Error for PerformError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            PerformError::Midi(e) => Some(&**e),
            PerformError::Robot(_) => None,
        }
    }
}

pub(crate) fn robot_err(e: impl std::fmt::Display) -> PerformError {
    PerformError::Robot(e.to_string())
}
