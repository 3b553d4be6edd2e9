//! The live interpreter's loop (`orch run`'s): it waits for the input's bytes and a front
//! end's requests ([`Event`]), with the guard's next deadline as its timeout (so the watchdog
//! lets go of every key when the input goes silent), steps the [`LiveRobot`], and tells the
//! front end what happened ([`Said`]) and, after each step, lets it look (a view, a log).

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant as Wall};

use orch_io::InEvent;
use orch_robot::{Robot, RobotError};

use crate::writes::BoardState;
use crate::{LiveError, LiveRobot, ReloadRefused};

/// What the loop waits for.
#[derive(Debug)]
pub enum Event {
    /// From the input's reader.
    In(InEvent),
    /// Read the robot's file again (`SIGHUP`).
    Reload,
    /// Say the counters (`SIGUSR1`).
    Counters,
    /// Stop (`SIGINT`, `SIGTERM`): every key released.
    Stop,
}

impl From<InEvent> for Event {
    fn from(e: InEvent) -> Self {
        Event::In(e)
    }
}

/// What the loop has to say.
#[derive(Debug)]
pub enum Said {
    /// A robot read again has taken over.
    TookOver,
    /// The input's device went away (every key released; it is tried again).
    Lost(std::io::Error),
    /// The input's device is back.
    Back,
    /// A network session began (RTP-MIDI): who.
    Joined(String),
    /// The network session ended (every key released): who, and why.
    Left(String),
    /// The counters, asked for or (verbose) once a second while bytes come.
    Counters(String),
    /// There is no robot file to read again: the thesis's robot stays.
    NoFile,
    /// The robot's file read again was refused; the robot stays as it was.
    Refused(PathBuf, RobotError),
    /// The robot's file read again cannot take over without a restart; the robot stays.
    CannotReload(PathBuf, ReloadRefused),
    /// The robot's file was read again; it takes over when no key is down.
    Read(PathBuf),
}

impl std::fmt::Display for Said {
    /// What happened in words, as `orch run` says it (after its own head: the input for
    /// [`Said::Lost`] and [`Said::Back`], the signal for a robot file read again).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let restart = "restart orch run for that; the robot stays as it was";
        match self {
            Said::TookOver => f.write_str("the new robot configuration is in force"),
            Said::Lost(e) => write!(
                f,
                "the device went away ({e}); every key released; it is tried again every {} ms",
                orch_io::RECONNECT_EVERY.as_millis()
            ),
            Said::Back => f.write_str("the device is back"),
            Said::Joined(who) => write!(f, "session with {who} open"),
            Said::Left(who) => write!(f, "session ended: {who}; every key released"),
            Said::Counters(c) => f.write_str(c),
            Said::NoFile => f.write_str("no --robot file to read again; the thesis's robot stays"),
            Said::Refused(path, e) => write!(
                f,
                "{} refused, the robot stays as it was: {e}",
                path.display()
            ),
            Said::CannotReload(path, ReloadRefused::MovesBoards) => {
                write!(f, "{} moves the I2C boards: {restart}", path.display())
            }
            Said::CannotReload(path, ReloadRefused::ChangesKinds) => write!(
                f,
                "{} changes the kind of a board (PCA9555, PCA9685): {restart}",
                path.display()
            ),
            Said::Read(path) => write!(
                f,
                "{} read; it takes over when no key is down",
                path.display()
            ),
        }
    }
}

/// Why the loop ended.
#[derive(Debug)]
pub enum End {
    /// The input ended.
    Input,
    /// Asked to stop ([`Event::Stop`]).
    Stopped,
    /// The front end asked to quit (its `after` hook).
    Quit,
    /// The input failed.
    InputFailed(std::io::Error),
    /// The robot failed.
    Failed(LiveError),
    /// The front end failed (its `after` hook, with its error).
    Front(Box<dyn std::error::Error + Send + Sync>),
}

/// How the loop runs, and the front end's part in it.
pub struct Loop<'a> {
    /// The robot's file, read again on [`Event::Reload`] (none: the thesis's robot).
    pub robot_path: Option<PathBuf>,
    /// How long the loop waits at most when no timer is due (a view's frame; lost I2C boards
    /// are tried again after it).
    pub every: Duration,
    /// Say the counters once a second while bytes come.
    pub verbose: bool,
    /// Told what happened.
    pub say: &'a mut dyn FnMut(Said),
    /// Called after each step: `Some` ends the loop.
    pub after: &'a mut dyn FnMut(&LiveRobot) -> Option<End>,
}

/// The counters in words.
pub fn counters(live: &LiveRobot) -> String {
    let t = live.totals();
    let c = t.counters;
    let (lost, cut) = live.lost();
    format!(
        "{} bytes in {} reads; {} messages; garbage: {} data bytes with no status, {} messages \
         cut short; {} notes: {} sounded, {} dropped; {} keys cut by the watchdog; {} board \
         writes; {} keys down; the input's device went away {} times ({} messages cut off)",
        c.bytes,
        live.reads(),
        c.messages,
        c.dropped,
        c.abandoned,
        t.note_ons,
        t.sounded,
        t.dropped,
        t.cut_by_watchdog,
        live.writes(),
        live.interpreter().keys_down(),
        lost,
        cut
    )
}

/// Every board's state when the loop has ended: its outputs (a PWM board's too, without its
/// duties: the write log has them).
pub fn end_state(live: &LiveRobot) -> Vec<BoardState> {
    live.outputs()
        .iter()
        .map(|&(address, outputs)| BoardState {
            address,
            outputs,
            duty: None,
        })
        .collect()
}

impl Loop<'_> {
    /// Runs `live` on `events` until the input ends, a stop, the front end or a failure.
    pub fn run(&mut self, live: &mut LiveRobot, events: &Receiver<Event>) -> End {
        let mut last_line = Wall::now();
        let mut activity = false;
        loop {
            let mut wait = self.every;
            if let Some(at) = live.next_deadline() {
                wait = wait.min(at.saturating_duration_since(Wall::now()));
            }
            let step = match events.recv_timeout(wait) {
                Ok(Event::In(InEvent::Bytes { at, bytes })) => {
                    activity = true;
                    live.bytes(at, &bytes)
                }
                Ok(Event::In(InEvent::End)) | Err(RecvTimeoutError::Disconnected) => {
                    return End::Input
                }
                Ok(Event::In(InEvent::Lost(e))) => {
                    (self.say)(Said::Lost(e));
                    live.line_lost()
                }
                Ok(Event::In(InEvent::Back)) => {
                    (self.say)(Said::Back);
                    Ok(())
                }
                Ok(Event::In(InEvent::Joined(who))) => {
                    (self.say)(Said::Joined(who));
                    Ok(())
                }
                Ok(Event::In(InEvent::Left(who))) => {
                    (self.say)(Said::Left(who));
                    live.line_lost()
                }
                Ok(Event::In(InEvent::Failed(e))) => return End::InputFailed(e),
                Ok(Event::Counters) => {
                    (self.say)(Said::Counters(counters(live)));
                    Ok(())
                }
                Ok(Event::Reload) => self.reload(live),
                Ok(Event::Stop) => return End::Stopped,
                Err(RecvTimeoutError::Timeout) => live.tick(),
            };
            if live.took_over() {
                (self.say)(Said::TookOver);
            }
            if let Err(e) = step {
                return End::Failed(e);
            }
            live.poll();
            if self.verbose && activity && last_line.elapsed() >= Duration::from_secs(1) {
                (self.say)(Said::Counters(counters(live)));
                last_line = Wall::now();
                activity = false;
            }
            if let Some(end) = (self.after)(live) {
                return end;
            }
        }
    }

    /// Reads the robot's file again; it takes over the first moment every key is up and no
    /// message is half received, so no held key is dropped; a refused file leaves the old one
    /// in force.
    fn reload(&mut self, live: &mut LiveRobot) -> Result<(), LiveError> {
        let Some(path) = self.robot_path.clone() else {
            (self.say)(Said::NoFile);
            return Ok(());
        };
        match Robot::load(&path).and_then(|r| r.interpreter().map(|_| r)) {
            Err(e) => (self.say)(Said::Refused(path, e)),
            Ok(new) => match live.reload(new) {
                Err(why) => (self.say)(Said::CannotReload(path, why)),
                Ok(()) => (self.say)(Said::Read(path)),
            },
        }
        live.apply_pending().map(|_| ())
    }
}
