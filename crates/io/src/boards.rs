//! Finger boards driven from this host: `orch-boards`' PCA9555 and PCA9685 drivers on any I2C
//! bus (Linux `/dev/i2c-N` through `linux-embedded-hal`, or the virtual robot's bus in tests),
//! made to survive a bad bus.
//!
//! [`ResilientBoards`] wraps a [`MixedBoardSet`] (each board on/off or PWM, as robot.toml
//! says; a PWM board gets the duties of the core's strike-and-hold profile):
//!
//! - a failed write (a NACK, a timeout, a lost arbitration) is tried again
//!   [`RETRIES`] times, pausing 100 µs, 200 µs, 400 µs between tries;
//! - a board that still does not answer is **lost**: said once (a `tracing` warning), left out
//!   while the other boards play on, and tried again with backoff (from 10 ms, doubling up to
//!   1 s of performance time); when it answers it is **re-initialised** (a PCA9555: outputs to
//!   0, then all pins outputs; a PCA9685: every channel off, its prescale, awake) and given
//!   the fingers (or duties) it should hold now;
//! - [`ResilientBoards::release_all`] turns every output of every board off, lost or not, for
//!   stopping.
//!
//! [`BoardsOut`] is a whole robot on such boards ([`LocalRobot`]: orch-core's interpreter and
//! guard) behind [`MidiOut`], so the performer drives it beside the virtual robot; its guard
//! timers run at their own time ([`MidiOut::next_deadline`]); at the end, and when dropped
//! (a panic unwinding), every finger is let go.

use std::time::Duration;

use embedded_hal::i2c::I2c;
use orch_boards::MixedBoardSet;
use orch_core::{full_or_off, on_off, BoardId, BoardKind, Config, Duty, FingerBoards, Instant};
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

/// The PCA9685's oscillator start-up at initialisation: a real wait.
struct Sleep;

impl embedded_hal::delay::DelayNs for Sleep {
    fn delay_ns(&mut self, ns: u32) {
        std::thread::sleep(Duration::from_nanos(ns.into()));
    }
}

/// Finger boards that survive a bad bus. See the [module notes](self).
#[derive(Debug)]
pub struct ResilientBoards<I2C> {
    set: MixedBoardSet<I2C, MAX_BOARDS>,
    lost: Vec<Option<Lost>>,
    /// What each board should hold: its 16 duties (an on/off board's are full or off).
    wanted: Vec<[Duty; 16]>,
    /// The PCA9685 boards' PWM frequency, Hz.
    pwm_hz: u32,
    now_us: u64,
    stats: BoardStats,
}

impl<I2C: TimedBus> ResilientBoards<I2C> {
    /// PCA9555 boards at these 7-bit addresses on `bus`: [`with_kinds`](Self::with_kinds)
    /// with every board on/off.
    pub fn new(bus: I2C, addresses: &[u8]) -> Result<Self, OutError> {
        let boards: Vec<(u8, BoardKind)> =
            addresses.iter().map(|&a| (a, BoardKind::OnOff)).collect();
        Self::with_kinds(bus, &boards, orch_boards::pca9685::DEFAULT_FREQUENCY_HZ)
    }

    /// Boards at these 7-bit addresses on `bus`, each of its kind (PCA9685 boards at `pwm_hz`),
    /// each initialised now; a board that does not answer is lost from the start (and tried
    /// again later). An error when there are more than [`MAX_BOARDS`], `pwm_hz` is one a
    /// PCA9685 cannot make, or none answers.
    pub fn with_kinds(bus: I2C, boards: &[(u8, BoardKind)], pwm_hz: u32) -> Result<Self, OutError> {
        if boards.iter().any(|b| b.1 == BoardKind::Pwm)
            && orch_boards::pca9685::Prescale::from_hz(pwm_hz).is_none()
        {
            return Err(OutError::Board(format!(
                "a PCA9685 cannot make {pwm_hz} Hz (24..=1526 Hz)"
            )));
        }
        let set = MixedBoardSet::with_boards(bus, boards).ok_or(OutError::TooManyBoards {
            boards: boards.len(),
        })?;
        let n = boards.len();
        let mut me = Self {
            set,
            lost: vec![None; n],
            wanted: vec![[Duty::OFF; 16]; n],
            pwm_hz,
            now_us: 0,
            stats: BoardStats::default(),
        };
        for i in 0..n {
            if me
                .try_hard(i, |set| set.init_board(i as u8, pwm_hz, &mut Sleep))
                .is_err()
            {
                me.lose(i);
            }
        }
        if n > 0 && me.lost.iter().all(Option::is_some) {
            let list: Vec<String> = boards.iter().map(|b| format!("{:#04x}", b.0)).collect();
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
    pub fn set(&self) -> &MixedBoardSet<I2C, MAX_BOARDS> {
        &self.set
    }

    /// The driver and its bus, to change (a test's fault injection).
    pub fn set_mut(&mut self) -> &mut MixedBoardSet<I2C, MAX_BOARDS> {
        &mut self.set
    }

    /// Tries every lost board whose backoff has passed.
    pub fn retry_lost(&mut self) {
        for i in 0..self.lost.len() {
            self.try_return(i);
        }
    }

    /// Turns every output of every board off, whatever the cache says and whether lost or not
    /// (each tried as a write is). For stopping: every finger up.
    pub fn release_all(&mut self) {
        self.set.invalidate();
        for i in 0..self.wanted.len() {
            self.wanted[i] = [Duty::OFF; 16];
            let address = self.set.addresses()[i];
            let id = BoardId {
                index: i as u8,
                address,
            };
            let off = [Duty::OFF; 16];
            if self.try_hard(i, |set| set.write_duties(id, &off)).is_err() && self.lost[i].is_none()
            {
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
            &mut MixedBoardSet<I2C, MAX_BOARDS>,
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
        let pwm_hz = self.pwm_hz;
        let back = self
            .set
            .init_board(i as u8, pwm_hz, &mut Sleep)
            .and_then(|()| {
                self.set.invalidate();
                self.set.write_duties(id, &wanted)
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

    /// Writes one board's on/off outputs: [`write_duties`](FingerBoards::write_duties) with a
    /// set bit fully on.
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        self.write_duties(board, &full_or_off(outputs))
    }

    /// Writes one board, trying again on a bus error; a board that is lost (or becomes lost
    /// now) keeps what it should hold for its return, and the write counts as done, so that
    /// the other boards are written. Only the driver's own errors (a layout that does not
    /// match the boards) come back. A PCA9555 gets the outputs whose duty is above 0.
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), Self::Error> {
        let i = usize::from(board.index);
        if i >= self.wanted.len() {
            return Err(orch_boards::Error::UnknownBoard(board.index));
        }
        self.wanted[i] = if self.set.kinds()[i] == BoardKind::Pwm {
            *duties
        } else {
            full_or_off(on_off(duties))
        };
        if self.lost[i].is_some() {
            self.try_return(i);
            return Ok(());
        }
        match self.try_hard(i, |set| set.write_duties(board, duties)) {
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
    /// A robot for `config` on `bus`, its boards PCA9555s at the addresses `config`'s layout
    /// names ([`with_kinds`](Self::with_kinds) with every board on/off).
    pub fn new(config: Config<MAX_BOARDS>, bus: I2C) -> Result<Self, OutError> {
        Self::with_kinds(config, &[], orch_boards::pca9685::DEFAULT_FREQUENCY_HZ, bus)
    }

    /// A robot for `config` on `bus`, its boards at the addresses `config`'s layout names,
    /// each of the kind `kinds` gives (on/off past its end), PCA9685 boards at `pwm_hz`.
    pub fn with_kinds(
        config: Config<MAX_BOARDS>,
        kinds: &[BoardKind],
        pwm_hz: u32,
        bus: I2C,
    ) -> Result<Self, OutError> {
        // Board i of the layout is board i of the set: every board up to the last one with
        // keys (the layout's unused room after it has none).
        let boards = &config.layout.boards;
        let n = boards.iter().rposition(|b| b.keys > 0).map_or(0, |i| i + 1);
        let boards: Vec<(u8, BoardKind)> = boards[..n]
            .iter()
            .enumerate()
            .map(|(i, b)| (b.address, kinds.get(i).copied().unwrap_or_default()))
            .collect();
        if !config.dynamics.is_on_off() && !boards.iter().any(|b| b.1 == BoardKind::Pwm) {
            return Err(OutError::Board(
                "the robot plays dynamics but none of its boards is a PCA9685".into(),
            ));
        }
        let boards = ResilientBoards::with_kinds(bus, &boards, pwm_hz)?;
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
