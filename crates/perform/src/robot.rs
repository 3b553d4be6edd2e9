//! A local robot: the interpreter of `orch-core` and a set of finger boards on this host.
//!
//! [`LocalRobot`] takes timed MIDI bytes, runs the interpreter (and its guard's timers at
//! their own deadlines), writes every board that changed at each instant (a chord on one
//! board is one bus write) and keeps the interpreter's account of every note
//! ([`NoteEvent`]) with the instant it was decided. The boards are any [`FingerBoards`]:
//! [`SimBoards`] (the virtual robot, driven through `orch-boards`' own driver so the real
//! driver runs in every play), or real boards.

use orch_boards::MixedBoardSet;
use orch_core::{Config, FingerBoards, Instant, Interpreter, NoteEvent};
use orch_sim::{BusError, Performance, SimConfig, VirtualRobot};

/// The most boards a host robot may have.
pub const MAX_BOARDS: usize = 16;
/// The most keys a host robot may have: one per MIDI note.
pub const MAX_KEYS: usize = 128;

/// The interpreter as a host runs it: room for any configuration.
pub type HostInterpreter = Interpreter<MAX_BOARDS, MAX_KEYS>;

/// The virtual robot behind `orch-boards`' drivers (PCA9555 and PCA9685 boards, as its
/// configuration says).
pub type SimBoards = MixedBoardSet<VirtualRobot, MAX_BOARDS>;

/// The PCA9685's 500 µs oscillator start-up at initialisation: the virtual chip needs no
/// wait (its model applies a duty at once), so none is spent.
struct NoWait;

impl embedded_hal::delay::DelayNs for NoWait {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// What goes wrong on a local robot.
#[derive(Debug)]
pub enum RobotError<E> {
    /// The configuration cannot run.
    Config(orch_core::ConfigError),
    /// A board write failed.
    Board {
        /// The board's address.
        address: u8,
        /// The driver's error.
        error: E,
    },
}

impl<E: core::fmt::Debug> core::fmt::Display for RobotError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RobotError::Config(e) => write!(f, "robot configuration: {e}"),
            RobotError::Board { address, error } => {
                write!(f, "board {address:#04x}: {error:?}")
            }
        }
    }
}

impl<E: core::fmt::Debug> std::error::Error for RobotError<E> {}

/// Boards whose notion of time the robot sets before each write (a simulated bus); real
/// boards ignore it.
pub trait Boards: FingerBoards {
    /// The present, before a write.
    fn set_time(&mut self, _t: Instant) {}
    /// When the boards are ready after initialisation, if they can tell.
    fn ready_at(&self) -> Option<Instant> {
        None
    }
}

impl Boards for SimBoards {
    fn set_time(&mut self, t: Instant) {
        self.bus_mut().set_time(t);
    }
    fn ready_at(&self) -> Option<Instant> {
        Some(Instant::from_micros(self.bus().bus().free_at().as_micros()))
    }
}

/// A virtual robot as `sim` says, with its boards initialised through the driver at t = 0.
pub fn sim_boards(sim: &SimConfig) -> Result<SimBoards, RobotError<orch_boards::Error<BusError>>> {
    let robot = VirtualRobot::new(sim.clone());
    let boards: Vec<(u8, orch_core::BoardKind)> = sim
        .boards
        .iter()
        .enumerate()
        .map(|(i, b)| (b.address, sim.kind(i)))
        .collect();
    let mut set = SimBoards::with_boards(robot, &boards).ok_or(RobotError::Config(
        orch_core::ConfigError::TooManyKeys {
            keys: boards.len(),
            capacity: MAX_BOARDS,
        },
    ))?;
    set.init(sim.pwm_hz, &mut NoWait)
        .map_err(|error| RobotError::Board { address: 0, error })?;
    Ok(set)
}

/// A note decision of the interpreter and when it was made (µs on the robot's clock).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decided {
    /// When.
    pub t_us: u64,
    /// What.
    pub event: NoteEvent,
}

/// The interpreter and its boards. See the [module notes](self).
#[derive(Debug)]
pub struct LocalRobot<B: Boards> {
    interp: HostInterpreter,
    boards: B,
    /// The instant whose changes are not yet on the boards.
    batch: Option<u64>,
    decided: Vec<Decided>,
    /// Some key plays velocity (a PWM key): the boards get duties
    /// ([`Interpreter::flush_duties`]), not on/off frames.
    duties: bool,
}

impl<B: Boards> LocalRobot<B> {
    /// A robot for `config` on `boards` (initialised).
    pub fn new(config: Config<MAX_BOARDS>, boards: B) -> Result<Self, RobotError<B::Error>> {
        Ok(Self {
            interp: HostInterpreter::new(config).map_err(RobotError::Config)?,
            boards,
            batch: None,
            decided: Vec::new(),
            duties: !config.dynamics.is_on_off(),
        })
    }

    /// The interpreter.
    pub fn interpreter(&self) -> &HostInterpreter {
        &self.interp
    }

    /// The boards.
    pub fn boards(&self) -> &B {
        &self.boards
    }

    /// The boards, to drive between the interpreter's writes (retry a lost board, say). What
    /// is written there must be what the interpreter last wrote (or all fingers up).
    pub fn boards_mut(&mut self) -> &mut B {
        &mut self.boards
    }

    /// Note decisions since the last call, in order.
    pub fn take_decided(&mut self) -> Vec<Decided> {
        std::mem::take(&mut self.decided)
    }

    /// Note decisions since the last call, in order, without a new allocation.
    pub fn drain_decided(&mut self) -> std::vec::Drain<'_, Decided> {
        self.decided.drain(..)
    }

    /// Feeds bytes arriving at `t_us` (never earlier than the previous ones).
    pub fn feed(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), RobotError<B::Error>> {
        if self.batch != Some(t_us) {
            self.advance(t_us)?;
        }
        let decided = &mut self.decided;
        self.interp
            .feed_slice_with(bytes, Instant::from_micros(t_us), &mut |event| {
                decided.push(Decided { t_us, event })
            });
        self.batch = Some(t_us);
        Ok(())
    }

    /// Puts the last instant's changes on the boards and runs every timer due before `t_us`.
    pub fn advance(&mut self, t_us: u64) -> Result<(), RobotError<B::Error>> {
        if let Some(t) = self.batch.take() {
            self.flush(t)?;
        }
        while let Some(due) = self.interp.next_deadline().filter(|d| d.as_micros() < t_us) {
            self.tick(due)?;
            if self.interp.next_deadline() == Some(due) {
                break;
            }
        }
        Ok(())
    }

    fn tick(&mut self, due: Instant) -> Result<(), RobotError<B::Error>> {
        let t_us = due.as_micros();
        let decided = &mut self.decided;
        self.interp
            .tick_with(due, &mut |event| decided.push(Decided { t_us, event }));
        self.flush(t_us)
    }

    /// Runs every timer still pending (delayed strikes, short presses, the watchdog), then
    /// releases everything. Returns when it ended.
    pub fn drain(&mut self, t_us: u64) -> Result<u64, RobotError<B::Error>> {
        self.advance(t_us)?;
        let mut end = t_us;
        while let Some(due) = self.interp.next_deadline() {
            end = end.max(due.as_micros());
            self.tick(due.max(Instant::from_micros(end)))?;
            if self.interp.next_deadline() == Some(due) {
                break;
            }
        }
        self.stop(end)
    }

    /// Releases every key at `t_us` (waiting strikes are stopped) and writes it.
    pub fn stop(&mut self, t_us: u64) -> Result<u64, RobotError<B::Error>> {
        self.advance(t_us)?;
        let decided = &mut self.decided;
        self.interp
            .all_off_with(Instant::from_micros(t_us), &mut |event| {
                decided.push(Decided { t_us, event })
            });
        self.flush(t_us)?;
        Ok(t_us)
    }

    fn flush(&mut self, t_us: u64) -> Result<(), RobotError<B::Error>> {
        self.boards.set_time(Instant::from_micros(t_us));
        let flushed = if self.duties {
            self.interp.flush_duties(&mut self.boards)
        } else {
            self.interp.flush(&mut self.boards)
        };
        flushed.map(|_| ()).map_err(|e| RobotError::Board {
            address: e.board.address,
            error: e.error,
        })
    }

    /// Whether each key is down now.
    pub fn keys_down(&self) -> Vec<bool> {
        let keys = self.interp.config().keys();
        (0..keys).map(|k| self.interp.is_down(k as u8)).collect()
    }

    /// The interpreter and the boards, to finish with.
    pub fn into_parts(self) -> (HostInterpreter, B) {
        (self.interp, self.boards)
    }
}

impl LocalRobot<SimBoards> {
    /// Hands the virtual robot's resolved presses to `f` (with `Keep::Presses`; see
    /// `VirtualRobot::drain_presses`).
    pub fn drain_presses(&mut self, f: impl FnMut(&orch_sim::Press)) {
        self.boards.bus_mut().drain_presses(f);
    }

    /// Ends a virtual robot's performance at `end_us` (after the keys are back up).
    pub fn finish(self, end_us: u64) -> (HostInterpreter, Performance) {
        let (interp, boards) = self.into_parts();
        (
            interp,
            boards.destroy().finish(Instant::from_micros(end_us)),
        )
    }
}
