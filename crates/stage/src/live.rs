//! The live interpreter loop: the thesis's interpreter board on a host. Live MIDI bytes in,
//! orch-core's interpreter and guard, finger boards out (the virtual robot, or PCA9555 and
//! PCA9685 boards on a Linux I2C bus), the stream passed on to `--thru` outputs, a robot
//! configuration swapped at the first moment every key is up.
//!
//! [`LiveRobot`] is the loop's state; the front end owns the loop itself (it waits on the
//! input with [`LiveRobot::next_deadline`] as its timeout, and on its signals and view) and
//! calls: [`bytes`](LiveRobot::bytes) for each read, [`tick`](LiveRobot::tick) when it woke
//! for a timer, [`line_lost`](LiveRobot::line_lost) when the input's device went away,
//! [`reload`](LiveRobot::reload) with a robot read again, [`stop`](LiveRobot::stop) at the
//! end. Each byte is fed with the time its read returned, in µs of the host's monotonic clock
//! from the first input byte (on a DIN line, spread back 320 µs a byte); between bytes the
//! guard's timers run at their own deadlines, so the watchdog lets go of every key when the
//! input goes silent. Every board write can be watched ([`BoardWrite`]).

use std::time::{Duration, Instant as Wall};

use orch_core::{BoardId, BoardKind, Counters, Duty, FingerBoards, Instant, KeyPhase, Stats};
use orch_io::{open_i2c, Channels, LinuxI2c, OutSpec, ResilientBoards, Target};
use orch_perform::{Boards as _, SimBoards};
use orch_robot::{HostInterpreter, Robot};

use crate::framer::Framer;
use crate::thru::Thru;
use crate::LiveError;

/// The finger boards a live robot drives.
pub enum LiveBoards {
    /// The virtual robot (its presses counted, not kept).
    Sim(Box<SimBoards>),
    /// Boards on this host's I2C bus.
    I2c(Box<ResilientBoards<LinuxI2c>>),
}

impl LiveBoards {
    /// Opens `spec` (`sim` or `i2c:DEVICE`) for `robot`.
    pub fn open(spec: &OutSpec, robot: &Robot) -> Result<Self, LiveError> {
        if spec.channels != Channels::ALL {
            return Err(LiveError::BadInput(format!(
                "--out {}: the robot takes every channel its robot.toml takes (`channels` there)",
                spec.text
            )));
        }
        match &spec.target {
            Target::Sim => Ok(LiveBoards::Sim(Box::new(sim(robot)?))),
            Target::I2c(path) => {
                let bus = open_i2c(&path.to_string_lossy())?;
                let boards: Vec<(u8, BoardKind)> = robot.config.layout.boards[..robot.boards]
                    .iter()
                    .zip(&robot.kinds)
                    .map(|(b, &kind)| (b.address, kind))
                    .collect();
                Ok(LiveBoards::I2c(Box::new(ResilientBoards::with_kinds(
                    bus,
                    &boards,
                    robot.pwm_hz,
                )?)))
            }
            _ => Err(LiveError::BadInput(format!(
                "--out {}: orch run drives finger boards (sim or i2c:DEVICE); a MIDI output goes \
                 in --thru",
                spec.text
            ))),
        }
    }

    /// Whether these are the virtual robot's boards.
    pub fn is_sim(&self) -> bool {
        matches!(self, LiveBoards::Sim(_))
    }
}

/// The virtual robot for `robot`, keeping only its presses (a live run has no end to report).
fn sim(robot: &Robot) -> Result<SimBoards, LiveError> {
    let config = orch_sim::SimConfig {
        keep: orch_sim::Keep::Presses,
        ..robot.sim_config()
    };
    orch_perform::sim_boards(&config)
        .map_err(|e| LiveError::Failed(format!("the virtual robot: {e}")))
}

/// One board write, as it went: when (µs from the first input byte), the byte that caused it
/// (none: a timer), the board, and what it drives after it (a PWM board: its duties too).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardWrite {
    /// When, µs from the first input byte.
    pub t_us: u64,
    /// The input byte that caused it, counted from 0; `None` for a timer's write.
    pub byte: Option<u64>,
    /// The board's 7-bit address.
    pub address: u8,
    /// The 16 outputs on (for a PWM board: those with a duty above 0).
    pub outputs: u16,
    /// A PWM board's 16 duties (0..=4095); `None` for an on/off board.
    pub duty: Option<[u16; 16]>,
}

/// Who watches the writes: called with each board write as it is made ([`LiveRobot::new`]).
pub type WriteLog = Box<dyn FnMut(&BoardWrite) + Send>;

/// The boards, with every write shown to the log.
struct Tap {
    out: LiveBoards,
    log: Option<WriteLog>,
    t_us: u64,
    byte: Option<u64>,
    writes: u64,
    strikes: u64,
    /// What each board is (PWM boards are written duties).
    kinds: Vec<BoardKind>,
}

impl Tap {
    fn show(&mut self, w: BoardWrite) {
        self.writes += 1;
        if let Some(log) = self.log.as_mut() {
            log(&w);
        }
    }

    fn set_time(&mut self, t_us: u64) {
        self.t_us = t_us;
        match &mut self.out {
            LiveBoards::Sim(b) => b.set_time(Instant::from_micros(t_us)),
            LiveBoards::I2c(b) => b.set_time(Instant::from_micros(t_us)),
        }
    }

    /// Housekeeping between writes: lost I2C boards tried again, the virtual robot's presses
    /// counted (and not kept).
    fn poll(&mut self, now_us: u64) {
        match &mut self.out {
            LiveBoards::Sim(b) => {
                let mut n = 0;
                b.bus_mut().drain_presses(|_| n += 1);
                self.strikes += n;
            }
            LiveBoards::I2c(b) => {
                if !b.lost_now().is_empty() {
                    b.set_time(Instant::from_micros(now_us.max(self.t_us)));
                    b.retry_lost();
                }
            }
        }
    }
}

impl FingerBoards for Tap {
    type Error = String;

    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), String> {
        self.show(BoardWrite {
            t_us: self.t_us,
            byte: self.byte,
            address: board.address,
            outputs,
            duty: None,
        });
        match &mut self.out {
            LiveBoards::Sim(b) => b.write_board(board, outputs).map_err(|e| format!("{e:?}")),
            LiveBoards::I2c(b) => b.write_board(board, outputs).map_err(|e| format!("{e:?}")),
        }
    }

    /// A robot with PWM boards: their duties, on/off boards' outputs as `write_board`'s.
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), String> {
        if self.kinds.get(board.index as usize) != Some(&BoardKind::Pwm) {
            return self.write_board(board, orch_core::on_off(duties));
        }
        self.show(BoardWrite {
            t_us: self.t_us,
            byte: self.byte,
            address: board.address,
            outputs: orch_core::on_off(duties),
            duty: Some(duties.map(|d| d.get())),
        });
        match &mut self.out {
            LiveBoards::Sim(b) => b.write_duties(board, duties).map_err(|e| format!("{e:?}")),
            LiveBoards::I2c(b) => b.write_duties(board, duties).map_err(|e| format!("{e:?}")),
        }
    }
}

/// What a live run counted, summed over the robot configurations it went through.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    /// The decoder's counters.
    pub counters: Counters,
    /// Note-Ons received.
    pub note_ons: u64,
    /// Notes that sounded (struck or folded).
    pub sounded: u64,
    /// Notes dropped, whatever the reason.
    pub dropped: u64,
    /// Keys cut by the watchdog.
    pub cut_by_watchdog: u64,
}

impl Totals {
    fn add(&mut self, c: Counters, s: &Stats) {
        self.counters.bytes += c.bytes;
        self.counters.messages += c.messages;
        self.counters.dropped += c.dropped;
        self.counters.abandoned += c.abandoned;
        self.note_ons += u64::from(s.note_ons);
        self.sounded += u64::from(s.played + s.folded);
        self.dropped += u64::from(s.dropped());
        self.cut_by_watchdog += u64::from(s.cut_by_watchdog);
    }
}

/// Why a robot read again cannot take over a live run (the run goes on with the one it has).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ReloadRefused {
    /// It moves the I2C boards (other addresses): a restart's job.
    MovesBoards,
    /// It changes a board's kind (PCA9555, PCA9685): a restart's job.
    ChangesKinds,
}

/// One byte on a DIN MIDI line: 10 bits at 31 250 baud.
const DIN_BYTE: Duration = Duration::from_micros(320);

/// The live interpreter loop's state. See the [module notes](self).
pub struct LiveRobot {
    robot: Robot,
    interp: HostInterpreter,
    tap: Tap,
    thru: Vec<Thru>,
    origin: Option<Wall>,
    /// The last instant fed (µs from the first byte): time never runs backwards.
    last_us: u64,
    index: u64,
    reads: u64,
    totals: Totals,
    /// Frames the input for the reload point (running status, messages half received).
    framer: Framer,
    pending: Option<Robot>,
    /// The input is a DIN line: a read's bytes arrived 320 µs apart.
    din: bool,
    /// Times the input's device went away.
    lost: u64,
    /// Messages cut off by the device going away.
    cut_by_loss: u64,
    /// A robot read again took over since [`took_over`](Self::took_over) was last asked.
    took_over: bool,
}

impl LiveRobot {
    /// `robot` on `boards`, the stream passed on to `thru`; `din`: the input is a DIN line
    /// (a read's bytes came 320 µs apart); `log` sees every board write.
    pub fn new(
        robot: Robot,
        boards: LiveBoards,
        thru: Vec<Thru>,
        din: bool,
        log: Option<WriteLog>,
    ) -> Result<Self, LiveError> {
        let interp = robot.interpreter()?;
        let kinds = robot.kinds.clone();
        Ok(Self {
            robot,
            interp,
            tap: Tap {
                out: boards,
                log,
                t_us: 0,
                byte: None,
                writes: 0,
                strikes: 0,
                kinds,
            },
            thru,
            origin: None,
            last_us: 0,
            index: 0,
            reads: 0,
            totals: Totals::default(),
            framer: Framer::default(),
            pending: None,
            din,
            lost: 0,
            cut_by_loss: 0,
            took_over: false,
        })
    }

    /// Whether a robot read again ([`reload`](Self::reload)) took over since the last call.
    pub fn took_over(&mut self) -> bool {
        std::mem::take(&mut self.took_over)
    }

    /// The robot in force.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The interpreter.
    pub fn interpreter(&self) -> &HostInterpreter {
        &self.interp
    }

    /// The boards.
    pub fn boards(&self) -> &LiveBoards {
        &self.tap.out
    }

    /// Now, µs from the first input byte (0 before it), never before the last byte fed.
    pub fn now_us(&self) -> u64 {
        self.origin
            .map_or(0, |o| o.elapsed().as_micros() as u64)
            .max(self.last_us)
    }

    /// When the loop should wake for the guard's next timer (none before the first byte).
    pub fn next_deadline(&self) -> Option<Wall> {
        let origin = self.origin?;
        let due = self.interp.next_deadline()?;
        Some(origin + Duration::from_micros(due.as_micros()))
    }

    fn flush(&mut self, t_us: u64, byte: Option<u64>) -> Result<(), LiveError> {
        self.tap.set_time(t_us);
        self.tap.byte = byte;
        let flushed = if self.robot.has_dynamics() {
            self.interp.flush_duties(&mut self.tap)
        } else {
            self.interp.flush(&mut self.tap)
        };
        flushed.map_err(|e| {
            LiveError::Failed(format!(
                "board {:#04x} failed: {}",
                e.board.address, e.error
            ))
        })?;
        Ok(())
    }

    /// Runs every timer due at or before `t_us`, each at its own deadline.
    fn timers(&mut self, t_us: u64) -> Result<(), LiveError> {
        while let Some(due) = self
            .interp
            .next_deadline()
            .filter(|d| d.as_micros() <= t_us)
        {
            self.interp.tick(due);
            self.flush(due.as_micros(), None)?;
            if self.interp.next_deadline() == Some(due) {
                break;
            }
        }
        Ok(())
    }

    /// Feeds one read that returned at `at`. On a DIN line the bytes of a read came in one
    /// after the other, 320 µs apart, the last of them when the read returned: each is fed at
    /// that time (never before the byte fed before it), not all at the time of the read.
    pub fn bytes(&mut self, at: Wall, bytes: &[u8]) -> Result<(), LiveError> {
        let din = self.din;
        let spread = |k: usize| -> Duration {
            if din {
                DIN_BYTE * (bytes.len() - 1 - k) as u32
            } else {
                Duration::ZERO
            }
        };
        let first = at.checked_sub(spread(0)).unwrap_or(at);
        let origin = *self.origin.get_or_insert(first);
        self.reads += 1;
        for (k, &byte) in bytes.iter().enumerate() {
            let arrived = at.checked_sub(spread(k)).unwrap_or(at);
            let t_us =
                (arrived.saturating_duration_since(origin).as_micros() as u64).max(self.last_us);
            self.last_us = t_us;
            self.timers(t_us)?;
            self.interp.feed(byte, Instant::from_micros(t_us));
            self.flush(t_us, Some(self.index))?;
            self.index += 1;
            self.framer.push(byte, Channels::ALL, &mut |_| {});
            for t in &mut self.thru {
                t.push(byte);
            }
            self.apply_pending()?;
        }
        Ok(())
    }

    /// The loop woke with no input: the timers due now run, a robot read again takes over if
    /// it can now.
    pub fn tick(&mut self) -> Result<(), LiveError> {
        if self.origin.is_some() {
            let now = self.now_us();
            self.timers(now)?;
        }
        self.apply_pending().map(|_| ())
    }

    /// Housekeeping after each step of the loop: lost I2C boards tried again, the virtual
    /// robot's presses counted.
    pub fn poll(&mut self) {
        let now = self.now_us();
        self.tap.poll(now);
    }

    /// `new` (robot.toml read again) takes over at the first moment every key is up (none
    /// down, waiting to strike or resting before a re-strike) and no message is half
    /// received, so no held key is dropped. Refused (the run goes on as it was) if it moves
    /// the I2C boards or changes a board's kind.
    pub fn reload(&mut self, new: Robot) -> Result<(), ReloadRefused> {
        let addresses = |r: &Robot| -> Vec<u8> {
            r.config.layout.boards[..r.boards]
                .iter()
                .map(|b| b.address)
                .collect()
        };
        if matches!(self.tap.out, LiveBoards::I2c(_)) && addresses(&new) != addresses(&self.robot) {
            return Err(ReloadRefused::MovesBoards);
        }
        if new.kinds != self.robot.kinds {
            return Err(ReloadRefused::ChangesKinds);
        }
        self.pending = Some(new);
        Ok(())
    }

    /// Swaps in a robot read again if every key is up and no message is half received.
    /// Returns whether it took over now.
    pub fn apply_pending(&mut self) -> Result<bool, LiveError> {
        if self.pending.is_none() {
            return Ok(false);
        }
        // A key's rest before a re-strike ends on a tick: one now (if the stream has begun).
        if self.origin.is_some() {
            let now = self.now_us();
            self.timers(now)?;
            self.interp.tick(Instant::from_micros(now));
            self.flush(now, None)?;
        }
        let keys = self.interp.config().keys();
        let all_up = (0..keys).all(|k| self.interp.key_phase(k as u8) == KeyPhase::Up);
        if !all_up || !self.framer.idle() {
            return Ok(false);
        }
        let Some(new) = self.pending.take() else {
            return Ok(false);
        };
        let mut interp = new.interpreter()?;
        if let Some(status) = self.framer.running_status() {
            // Running status goes on across the swap.
            interp.feed(status, Instant::from_micros(self.last_us));
        }
        if let LiveBoards::Sim(_) = self.tap.out {
            self.tap.out = LiveBoards::Sim(Box::new(sim(&new)?));
        }
        self.totals.add(self.interp.counters(), self.interp.stats());
        self.interp = interp;
        self.robot = new;
        self.took_over = true;
        Ok(true)
    }

    /// The input's device went away: a message it cut off is forgotten (the next connection
    /// starts afresh, no running status), every key is released, and the thru outputs get
    /// All Notes Off on their channels (what was held there has lost its Note-Offs too).
    pub fn line_lost(&mut self) -> Result<(), LiveError> {
        self.lost += 1;
        if self.interp.input_ended() {
            self.cut_by_loss += 1;
        }
        self.framer = Framer::default();
        for t in &mut self.thru {
            t.line_lost();
        }
        let t = self.now_us();
        self.timers(t)?;
        self.interp.all_off(Instant::from_micros(t));
        self.flush(t, None)
    }

    /// The end: every key released on the boards (an I2C robot's every board written off,
    /// lost or not), then every thru output given All Notes Off and closed. Both are done
    /// whatever fails; the first failure comes back.
    pub fn stop(&mut self) -> Result<(), LiveError> {
        let t = self.now_us();
        let released = self.timers(t).and_then(|()| {
            self.interp.all_off(Instant::from_micros(t));
            self.flush(t, None)
        });
        if let LiveBoards::I2c(b) = &mut self.tap.out {
            b.release_all();
        }
        let mut thru = Ok(());
        for t in std::mem::take(&mut self.thru) {
            if let Err(e) = t.stop() {
                thru = Err(e);
            }
        }
        released.and(thru)
    }

    /// What was counted so far, over every configuration the run went through.
    pub fn totals(&self) -> Totals {
        let mut t = self.totals;
        t.add(self.interp.counters(), self.interp.stats());
        t
    }

    /// Reads of the input so far.
    pub fn reads(&self) -> u64 {
        self.reads
    }

    /// Board writes so far.
    pub fn writes(&self) -> u64 {
        self.tap.writes
    }

    /// Times the input's device went away, and the messages that cut off.
    pub fn lost(&self) -> (u64, u64) {
        (self.lost, self.cut_by_loss)
    }

    /// Seconds since the first input byte, as last fed.
    pub fn elapsed_s(&self) -> f64 {
        self.last_us as f64 / 1e6
    }

    /// Whether each key is down now.
    pub fn keys_down(&self) -> Vec<bool> {
        let keys = self.interp.config().keys();
        (0..keys).map(|k| self.interp.is_down(k as u8)).collect()
    }

    /// Every board's address and the outputs it should drive now, in layout order.
    pub fn outputs(&self) -> Vec<(u8, u16)> {
        self.interp.config().layout.boards[..self.robot.boards]
            .iter()
            .enumerate()
            .map(|(i, b)| (b.address, self.interp.frame().outputs(i)))
            .collect()
    }
}
