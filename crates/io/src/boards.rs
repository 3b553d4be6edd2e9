//! Finger boards driven from this host: `orch-boards`' PCA9555 driver on any I2C bus (Linux
//! `/dev/i2c-N` through `linux-embedded-hal`, or the virtual robot's bus in tests), made to
//! survive a bad bus.
//!
//! [`ResilientBoards`] wraps a [`FingerBoardSet`]:
//!
//! - a failed write (a NACK, a timeout, a lost arbitration) is tried again
//!   [`RETRIES`] times, pausing 100 µs, 200 µs, 400 µs between tries;
//! - a board that still does not answer is **lost**: said once (a `tracing` warning), left out
//!   while the other boards play on, and tried again with backoff (from 10 ms, doubling up to
//!   1 s of performance time); when it answers it is **re-initialised** (outputs to 0, then
//!   all pins outputs) and given the fingers it should hold now;
//! - [`ResilientBoards::release_all`] writes 0 to every board, lost or not, for stopping.
//!
//! [`BoardsOut`] is a whole robot on such boards ([`LocalRobot`]: orch-core's interpreter and
//! guard) behind [`MidiOut`], so the performer drives it beside the virtual robot; its guard
//! timers run at their own time ([`MidiOut::next_deadline`]); at the end, and when dropped
//! (a panic unwinding), every finger is let go.

use std::time::Duration;

use embedded_hal::i2c::I2c;
use orch_boards::FingerBoardSet;
use orch_core::{BoardId, Config, FingerBoards, Instant};
use orch_perform::{Boards, LocalRobot, MidiOut, MAX_BOARDS};

use crate::OutError;

/// Tries after the first failed write, before a board counts as lost.
pub const RETRIES: u32 = 3;
/// The first wait before trying a lost board again, µs of performance time.
pub const LOST_FIRST_BACKOFF_US: u64 = 10_000;
/// The longest wait between two tries of a lost board, µs.
pub const LOST_MAX_BACKOFF_US: u64 = 1_000_000;

/// An I2C bus as [`ResilientBoards`] uses it: it can be told the time (a simulated bus) and
/// paused between retries (a real bus sleeps).
pub trait TimedBus: I2c {
    /// The performance's present, µs, before each batch of writes.
    fn set_time(&mut self, _t_us: u64) {}
    /// Waits `d` before a retry.
    fn pause(&mut self, d: Duration) {
        std::thread::sleep(d);
    }
}

/// A Linux I2C bus (`/dev/i2c-N`, the kernel's `i2c-dev`), through `linux-embedded-hal`.
pub struct LinuxI2c {
    dev: linux_embedded_hal::I2cdev,
    path: String,
}

impl std::fmt::Debug for LinuxI2c {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LinuxI2c")
            .field("path", &self.path)
            .finish()
    }
}

impl embedded_hal::i2c::ErrorType for LinuxI2c {
    type Error = linux_embedded_hal::I2CError;
}

impl I2c for LinuxI2c {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [embedded_hal::i2c::Operation<'_>],
    ) -> Result<(), Self::Error> {
        self.dev.transaction(address, operations)
    }
}

impl TimedBus for LinuxI2c {}

/// Opens a Linux I2C bus (`/dev/i2c-1`).
pub fn open_i2c(path: &str) -> Result<LinuxI2c, OutError> {
    let dev = linux_embedded_hal::I2cdev::new(path).map_err(|e| OutError::Open {
        device: path.into(),
        source: std::io::Error::other(e),
    })?;
    Ok(LinuxI2c {
        dev,
        path: path.into(),
    })
}

/// What happened on the boards, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoardStats {
    /// Writes tried again after a failure.
    pub retries: u64,
    /// Writes that failed (every try counted).
    pub failed_writes: u64,
    /// Times a board was lost.
    pub lost: u64,
    /// Times a lost board answered again and was re-initialised.
    pub reinitialised: u64,
}

#[derive(Clone, Copy, Debug)]
struct Lost {
    next_try_us: u64,
    backoff_us: u64,
}

/// Finger boards that survive a bad bus. See the [module notes](self).
#[derive(Debug)]
pub struct ResilientBoards<I2C> {
    set: FingerBoardSet<I2C, MAX_BOARDS>,
    lost: Vec<Option<Lost>>,
    wanted: Vec<u16>,
    now_us: u64,
    stats: BoardStats,
}

impl<I2C: TimedBus> ResilientBoards<I2C> {
    /// Boards at these 7-bit addresses on `bus`, each initialised now; a board that does not
    /// answer is lost from the start (and tried again later). An error only when there are
    /// more than [`MAX_BOARDS`] or none answers.
    pub fn new(bus: I2C, addresses: &[u8]) -> Result<Self, OutError> {
        let set = FingerBoardSet::with_boards(bus, addresses).ok_or(OutError::TooManyBoards {
            boards: addresses.len(),
        })?;
        let n = addresses.len();
        let mut me = Self {
            set,
            lost: vec![None; n],
            wanted: vec![0; n],
            now_us: 0,
            stats: BoardStats::default(),
        };
        for i in 0..n {
            if me.try_hard(i, |set| set.init_board(i as u8)).is_err() {
                me.lose(i);
            }
        }
        if n > 0 && me.lost.iter().all(Option::is_some) {
            let list: Vec<String> = addresses.iter().map(|a| format!("{a:#04x}")).collect();
            return Err(OutError::NoBoard {
                addresses: list.join(", "),
            });
        }
        Ok(me)
    }

    /// What happened so far.
    pub fn stats(&self) -> BoardStats {
        self.stats
    }

    /// The boards lost now, by address.
    pub fn lost_now(&self) -> Vec<u8> {
        self.lost
            .iter()
            .zip(self.set.addresses())
            .filter(|(l, _)| l.is_some())
            .map(|(_, &a)| a)
            .collect()
    }

    /// The driver and its bus.
    pub fn set(&self) -> &FingerBoardSet<I2C, MAX_BOARDS> {
        &self.set
    }

    /// The driver and its bus, to change (a test's fault injection).
    pub fn set_mut(&mut self) -> &mut FingerBoardSet<I2C, MAX_BOARDS> {
        &mut self.set
    }

    /// Tries every lost board whose backoff has passed.
    pub fn retry_lost(&mut self) {
        for i in 0..self.lost.len() {
            self.try_return(i);
        }
    }

    /// Writes 0 to every board, whatever the cache says and whether lost or not (each tried
    /// as a write is). For stopping: every finger up.
    pub fn release_all(&mut self) {
        self.set.invalidate();
        for i in 0..self.wanted.len() {
            self.wanted[i] = 0;
            let address = self.set.addresses()[i];
            let id = BoardId {
                index: i as u8,
                address,
            };
            if self.try_hard(i, |set| set.write_board(id, 0)).is_err() && self.lost[i].is_none() {
                self.lose(i);
            }
        }
    }

    /// Runs `f` and, while it fails with a bus error, up to [`RETRIES`] more times with
    /// backoff.
    fn try_hard(
        &mut self,
        _i: usize,
        mut f: impl FnMut(
            &mut FingerBoardSet<I2C, MAX_BOARDS>,
        ) -> Result<(), orch_boards::Error<I2C::Error>>,
    ) -> Result<(), orch_boards::Error<I2C::Error>> {
        let mut pause = Duration::from_micros(100);
        let mut tries = 0;
        loop {
            match f(&mut self.set) {
                Ok(()) => return Ok(()),
                Err(e) => {
                    self.stats.failed_writes += 1;
                    if e.i2c().is_none() || tries == RETRIES {
                        return Err(e);
                    }
                    tracing::debug!(error = ?e, "I2C write failed; trying again");
                    self.set.bus_mut().pause(pause);
                    pause *= 2;
                    tries += 1;
                    self.stats.retries += 1;
                }
            }
        }
    }

    fn lose(&mut self, i: usize) {
        self.stats.lost += 1;
        let address = self.set.addresses()[i];
        tracing::warn!(
            board = format_args!("{address:#04x}"),
            "finger board not answering: its keys are silent, the other boards play on; \
             it will be re-initialised when it answers"
        );
        self.lost[i] = Some(Lost {
            next_try_us: self.now_us + LOST_FIRST_BACKOFF_US,
            backoff_us: LOST_FIRST_BACKOFF_US,
        });
    }

    fn try_return(&mut self, i: usize) {
        let Some(lost) = self.lost[i] else {
            return;
        };
        if self.now_us < lost.next_try_us {
            return;
        }
        let wanted = self.wanted[i];
        let address = self.set.addresses()[i];
        let id = BoardId {
            index: i as u8,
            address,
        };
        let back = self.set.init_board(i as u8).and_then(|()| {
            self.set.invalidate();
            self.set.write_board(id, wanted)
        });
        match back {
            Ok(()) => {
                self.lost[i] = None;
                self.stats.reinitialised += 1;
                tracing::warn!(
                    board = format_args!("{address:#04x}"),
                    "finger board answers again: re-initialised"
                );
            }
            Err(_) => {
                self.stats.failed_writes += 1;
                let backoff_us = (lost.backoff_us * 2).min(LOST_MAX_BACKOFF_US);
                self.lost[i] = Some(Lost {
                    next_try_us: self.now_us + backoff_us,
                    backoff_us,
                });
            }
        }
    }
}

impl<I2C: TimedBus> FingerBoards for ResilientBoards<I2C> {
    type Error = orch_boards::Error<I2C::Error>;

    /// Writes one board, trying again on a bus error; a board that is lost (or becomes lost
    /// now) keeps what it should hold for its return, and the write counts as done, so that
    /// the other boards are written. Only the driver's own errors (a layout that does not
    /// match the boards) come back.
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        let i = usize::from(board.index);
        if i >= self.wanted.len() {
            return Err(orch_boards::Error::UnknownBoard(board.index));
        }
        self.wanted[i] = outputs;
        if self.lost[i].is_some() {
            self.try_return(i);
            return Ok(());
        }
        match self.try_hard(i, |set| set.write_board(board, outputs)) {
            Ok(()) => Ok(()),
            Err(e) if e.i2c().is_none() => Err(e),
            Err(_) => {
                self.lose(i);
                Ok(())
            }
        }
    }
}

impl<I2C: TimedBus> Boards for ResilientBoards<I2C> {
    fn set_time(&mut self, t: Instant) {
        self.now_us = t.as_micros();
        self.set.bus_mut().set_time(self.now_us);
    }
}

/// The refusal of a robot with PCA9685 boards on a Linux I2C bus.
pub(crate) fn pwm_unsupported() -> OutError {
    OutError::Board(
        "PCA9685 (PWM) boards on a Linux I2C bus are not driven yet: i2c outputs drive \
         PCA9555/TCA9555 boards (the virtual robot and orch interpret play PCA9685 ones)"
            .into(),
    )
}

/// A robot on finger boards driven from this host, as a [`MidiOut`]. See the
/// [module notes](self).
#[derive(Debug)]
pub struct BoardsOut<I2C: TimedBus> {
    robot: LocalRobot<ResilientBoards<I2C>>,
    /// Timers are run up to here (exclusive).
    polled_to: u64,
    /// An instant fed but not yet on the boards.
    pending: Option<u64>,
    finished: bool,
}

impl<I2C: TimedBus> BoardsOut<I2C> {
    /// A robot for `config` on `bus`, its boards at the addresses `config`'s layout names.
    pub fn new(config: Config<MAX_BOARDS>, bus: I2C) -> Result<Self, OutError> {
        if !config.dynamics.is_on_off() {
            return Err(pwm_unsupported());
        }
        // Board i of the layout is board i of the set: every board up to the last one with
        // keys (the layout's unused room after it has none).
        let boards = &config.layout.boards;
        let n = boards.iter().rposition(|b| b.keys > 0).map_or(0, |i| i + 1);
        let addresses: Vec<u8> = boards[..n].iter().map(|b| b.address).collect();
        let boards = ResilientBoards::new(bus, &addresses)?;
        let robot = LocalRobot::new(config, boards).map_err(|e| OutError::Board(e.to_string()))?;
        Ok(Self {
            robot,
            polled_to: 0,
            pending: None,
            finished: false,
        })
    }

    /// The boards.
    pub fn boards(&self) -> &ResilientBoards<I2C> {
        self.robot.boards()
    }

    /// The boards, to change (a test's fault injection).
    pub fn boards_mut(&mut self) -> &mut ResilientBoards<I2C> {
        self.robot.boards_mut()
    }

    /// The robot.
    pub fn robot(&self) -> &LocalRobot<ResilientBoards<I2C>> {
        &self.robot
    }
}

impl<I2C: TimedBus> MidiOut for BoardsOut<I2C> {
    type Error = OutError;

    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), OutError> {
        self.robot.boards_mut().set_time(Instant::from_micros(t_us));
        self.robot.boards_mut().retry_lost();
        self.robot
            .feed(t_us, bytes)
            .map_err(|e| OutError::Board(e.to_string()))?;
        // This instant goes on the boards when the performer has sent all of it (a chord on
        // one board is one write): it polls at `pending` before anything later.
        self.pending = Some(t_us);
        Ok(())
    }

    fn next_deadline(&self) -> Option<u64> {
        let timer = self
            .robot
            .interpreter()
            .next_deadline()
            .map(|d| d.as_micros())
            .filter(|&d| d >= self.polled_to);
        match (self.pending, timer) {
            (Some(p), Some(t)) => Some(p.min(t)),
            (p, t) => p.or(t),
        }
    }

    fn poll(&mut self, t_us: u64) -> Result<(), OutError> {
        self.robot.boards_mut().set_time(Instant::from_micros(t_us));
        self.robot.boards_mut().retry_lost();
        self.robot
            .advance(t_us + 1)
            .map_err(|e| OutError::Board(e.to_string()))?;
        self.pending = None;
        self.polled_to = self.polled_to.max(t_us + 1);
        Ok(())
    }

    fn finish(&mut self, t_us: u64) -> Result<(), OutError> {
        let t = t_us.max(self.polled_to);
        self.robot
            .stop(t)
            .map_err(|e| OutError::Board(e.to_string()))?;
        self.robot.boards_mut().release_all();
        self.finished = true;
        Ok(())
    }
}

impl<I2C: TimedBus> Drop for BoardsOut<I2C> {
    /// Unless finished, every finger up (a panic or an error on the way).
    fn drop(&mut self) {
        if !self.finished {
            self.robot.boards_mut().release_all();
        }
    }
}
