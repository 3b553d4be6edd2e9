//! A song played on its robots, from one description: [`Play`], which a front end tells once
//! what it wants (the file, the robot, the outputs, the tempo, the bar to start from, the
//! virtual or the real clock, who watches, which files it leaves) and which loads, sets up,
//! plays and accounts, and gives back every robot's end ([`Performed`]) for the report.
//!
//! ```
//! use orch_stage::play::Play;
//!
//! let song = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/ode-to-joy.mid");
//! let performed = Play::file(song).tempo(2.0).fast(true).run()?;
//! let orch_stage::Reports::One(report) = performed.reports() else { unreachable!() };
//! assert_eq!(report.notes, 114);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod files;

use std::convert::Infallible;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use orch_io::Target;
use orch_perform::{Control, Setup};
use orch_seq::{Clock, Song};

pub use error::{Leaves, PlayError};

use files::Files;

use crate::session::{self, Ended, Lane, MakeClock, Session};
use crate::watch::{self, Watched};
use crate::Reports;

/// What a front end watches a live play with: called over and over with the session until
/// every robot has finished; an error stops every robot.
type Watcher<'a, E> = Box<dyn FnMut(&Session) -> Result<(), E> + 'a>;

/// A song to play on its robots. See the [module notes](self).
///
/// Left alone it plays the file on the thesis's robot, compensated, at the written tempo, on
/// the virtual robot (`sim`), live on the host's clock, from the start, with nobody watching.
pub struct Play<'a, E = Infallible> {
    file: PathBuf,
    robot: Option<PathBuf>,
    outs: Vec<String>,
    tempo: f64,
    from_bar: Option<u32>,
    compensation: bool,
    fast: bool,
    notes: Option<PathBuf>,
    writes: Option<PathBuf>,
    steer: Option<(Arc<Control>, Instant)>,
    clocks: Option<MakeClock>,
    watcher: Option<Watcher<'a, E>>,
}

/// How a play ended: every robot's end, in the order of the outputs.
pub struct Performed {
    /// Every robot's end.
    pub ended: Vec<Ended>,
    /// Whether outputs were named (then each robot's report says where it played).
    pub named: bool,
    /// Whether the OS refused real-time priority to a sender (its messages may then be late
    /// under load; the report's lateness says). Never on the virtual clock.
    pub priority_refused: bool,
}

impl Performed {
    /// Every robot's report ([`Reports::of`]).
    pub fn reports(&self) -> Reports {
        Reports::of(&self.ended, self.named)
    }
}

impl Play<'static> {
    /// The Standard MIDI File at `file`, to play.
    pub fn file(file: impl Into<PathBuf>) -> Self {
        Self {
            file: file.into(),
            robot: None,
            outs: Vec::new(),
            tempo: 1.0,
            from_bar: None,
            compensation: true,
            fast: false,
            notes: None,
            writes: None,
            steer: None,
            clocks: None,
            watcher: None,
        }
    }
}

impl<'a, E> Play<'a, E> {
    /// The robot in `robot` (a robot.toml); the thesis's robot when none.
    pub fn robot<'p>(mut self, robot: impl Into<Option<&'p Path>>) -> Self {
        self.robot = robot.into().map(Path::to_path_buf);
        self
    }

    /// Plays on the outputs `outs` name (as [`orch_io::OutSpec::parse`] takes them), a robot
    /// each; the virtual robot alone when there is none.
    pub fn outs<S: Into<String>>(mut self, outs: impl IntoIterator<Item = S>) -> Self {
        self.outs = outs.into_iter().map(Into::into).collect();
        self
    }

    /// At tempo factor `factor` (1.0: as written; see [`crate::setup::tempo`]).
    pub fn tempo(mut self, factor: f64) -> Self {
        self.tempo = factor;
        self
    }

    /// From the start of bar `bar` (counted from 1), if given; the notes before it are
    /// skipped.
    pub fn from_bar(mut self, bar: impl Into<Option<u32>>) -> Self {
        self.from_bar = bar.into();
        self
    }

    /// Each message sent early by its key's mechanical delay (the default), or not.
    pub fn compensation(mut self, on: bool) -> Self {
        self.compensation = on;
        self
    }

    /// On the virtual clock, as fast as the machine goes (the virtual robot alone), instead
    /// of live.
    pub fn fast(mut self, fast: bool) -> Self {
        self.fast = fast;
        self
    }

    /// Writes the note-by-note account to `path` when the play has ended, if given (the file
    /// is created before anything plays).
    pub fn notes_to<'p>(mut self, path: impl Into<Option<&'p Path>>) -> Self {
        self.notes = path.into().map(Path::to_path_buf);
        self
    }

    /// Writes every board write to `path` when the play has ended, if given (created before
    /// anything plays; every write is then kept).
    pub fn writes_to<'p>(mut self, path: impl Into<Option<&'p Path>>) -> Self {
        self.writes = path.into().map(Path::to_path_buf);
        self
    }

    /// Steered by `control` (a conductor's, say) on a clock whose zero is `origin`, instead
    /// of a control and a clock of its own.
    pub fn steered_by(mut self, control: Arc<Control>, origin: Instant) -> Self {
        self.steer = Some((control, origin));
        self
    }

    /// Each robot paced by a clock `make` makes, instead of the host's precise clock: each
    /// must count from the play's origin (see [`steered_by`](Self::steered_by)). Live only.
    pub fn clock(
        mut self,
        make: impl Fn() -> Box<dyn Clock + Send> + Send + Sync + 'static,
    ) -> Self {
        self.clocks = Some(Arc::new(make));
        self
    }

    /// Watched live by `watch`: called with the session over and over until every robot
    /// has finished (it should wait a little each time). An error from it, or a panic, stops
    /// every robot, then is given back ([`PlayError::Live`]).
    pub fn watch<'b, F>(self, watch: impl FnMut(&Session) -> Result<(), F> + 'b) -> Play<'b, F> {
        Play {
            file: self.file,
            robot: self.robot,
            outs: self.outs,
            tempo: self.tempo,
            from_bar: self.from_bar,
            compensation: self.compensation,
            fast: self.fast,
            notes: self.notes,
            writes: self.writes,
            steer: self.steer,
            clocks: self.clocks,
            watcher: Some(Box::new(watch)),
        }
    }

    /// Loads the song and the robot, opens the outputs, plays to the end (or until stopped),
    /// and writes the files asked for. Every input is checked before anything plays, in the
    /// order: the song, the bar, the robot, the tempo, the files, the outputs.
    pub fn run(self) -> Result<Performed, PlayError<E>> {
        let song = crate::load_song(&self.file).map_err(PlayError::Song)?;
        let from_us = match self.from_bar {
            Some(bar) => Some(
                crate::bars::start_of(&song, bar)
                    .map_err(|error| PlayError::From { bar, error })?,
            ),
            None => None,
        };
        let robot = crate::load_robot(self.robot.as_deref()).map_err(PlayError::Robot)?;
        let tempo = crate::setup::tempo(self.tempo).map_err(|error| PlayError::Tempo {
            factor: self.tempo,
            error,
        })?;
        let mut setup = crate::setup::setup(&robot, self.compensation, tempo);
        if self.writes.is_some() {
            // Every write is kept for the file, not only the presses the report needs.
            setup.sim.keep = orch_sim::Keep::Everything;
        }
        let mut files = Files::create(self.writes.as_deref(), self.notes.as_deref())?;
        let lanes = lanes(&self.outs, self.fast, &setup)?;
        let named = !self.outs.is_empty();
        let (ended, priority_refused, song) = if self.fast {
            let ended =
                crate::setup::play_lanes_fast(&song, lanes, from_us).map_err(PlayError::Fast)?;
            (ended, false, Some(song))
        } else {
            // The song is kept for the account's bars and beats (a live play takes it).
            let kept = files.wants_song().then(|| song.clone());
            let live = Live {
                steer: self.steer,
                clocks: self.clocks,
                watcher: self.watcher,
            };
            let watched = live.play(song, lanes, from_us);
            let priority_refused = watched.priority_refused;
            let ended = watched.result.map_err(|error| PlayError::Live {
                priority_refused,
                error,
            })?;
            (ended, priority_refused, kept)
        };
        files.write(song.as_ref(), &ended, setup.tempo)?;
        Ok(Performed {
            ended,
            named,
            priority_refused,
        })
    }
}

/// The outputs `outs` name, opened, one robot (a lane) each; on the virtual clock, the
/// virtual robot alone.
fn lanes<E>(outs: &[String], fast: bool, setup: &Setup) -> Result<Vec<Lane>, PlayError<E>> {
    let specs = session::out_specs(outs).map_err(PlayError::Out)?;
    if fast {
        if let Some(s) = specs.iter().find(|s| s.target != Target::Sim) {
            return Err(PlayError::FastOut(s.text.clone()));
        }
    }
    session::open_lanes(specs, setup).map_err(PlayError::Out)
}

/// How a live play is steered, paced and watched.
struct Live<'a, E> {
    steer: Option<(Arc<Control>, Instant)>,
    clocks: Option<MakeClock>,
    watcher: Option<Watcher<'a, E>>,
}

impl<E> Live<'_, E> {
    /// Plays `song` on `lanes` from `from_us`, if given, watched to its end.
    fn play(self, song: Song, lanes: Vec<Lane>, from_us: Option<u64>) -> Watched<E> {
        let (control, origin) = self
            .steer
            .unwrap_or_else(|| (Control::new(), Instant::now()));
        if let Some(t) = from_us {
            control.jump_to(t);
        }
        let clocks = self
            .clocks
            .unwrap_or_else(|| session::precise_clocks(origin));
        let session = Session::start_clocked(song, lanes, control, origin, clocks);
        match self.watcher {
            Some(watcher) => watch::watch_session(session, watcher),
            None => watch::watch_session(session, |_| {
                std::thread::sleep(std::time::Duration::from_millis(20));
                Ok(())
            }),
        }
    }
}
