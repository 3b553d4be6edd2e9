//! `orch run --in IN --out OUT`: the thesis's ATmega16 job on a Linux host. Live MIDI bytes
//! in (a DIN line through a UART, a raw MIDI device, UDP, standard input), orch-core's
//! interpreter and guard, finger boards out (the virtual robot, or PCA9555 boards on the
//! host's I2C bus), and the stream passed through to other MIDI outputs (`--thru`).
//!
//! Each byte is fed with the time its read returned, in µs of the host's monotonic clock from
//! the first input byte; between bytes the guard's timers run at their own deadlines (the
//! main loop waits on the input with the next deadline as its timeout), so the watchdog lets
//! go of every key when the input goes silent.

use std::io::{BufWriter, IsTerminal, Stdout, Write};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant as Wall};

use orch_core::{BoardId, Counters, FingerBoards, Instant, KeyPhase, Stats};
use orch_io::{
    midi::all_notes_off, open_i2c, Channels, InEvent, InTarget, LinuxI2c, MidiIn, OutSpec, Output,
    ResilientBoards, Target,
};
use orch_perform::{Boards as _, MidiOut, SimBoards};
use serde_json::json;

use crate::cli::RunArgs;
use crate::error::bad_input;
use crate::robot::{HostInterpreter, Robot};
use crate::view::{Scene, View};

/// What the main loop waits for.
#[derive(Debug)]
pub enum Event {
    /// From the input's reader.
    In(InEvent),
    /// A signal arrived.
    Signal(i32),
}

impl From<InEvent> for Event {
    fn from(e: InEvent) -> Self {
        Event::In(e)
    }
}

/// The finger boards `orch run` drives.
enum Out {
    Sim(Box<SimBoards>),
    I2c(Box<ResilientBoards<LinuxI2c>>),
}

/// The boards, with every write printed as `orch interpret --json` prints it when asked.
struct Tap {
    out: Out,
    json: Option<BufWriter<Stdout>>,
    /// When the writes being made happen (µs from the first input byte).
    t_us: u64,
    /// The input byte that causes them (none: a timer).
    byte: Option<u64>,
    writes: u64,
    strikes: u64,
    /// What each board is (PWM boards are written duties).
    kinds: Vec<orch_core::BoardKind>,
}

impl FingerBoards for Tap {
    type Error = String;

    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), String> {
        self.writes += 1;
        if let Some(w) = self.json.as_mut() {
            let line = json!({"t_us": self.t_us, "byte": self.byte, "address": board.address, "outputs": outputs});
            if writeln!(w, "{line}").is_err() {
                // Standard output gone (a closed pipe): the robot plays on without the log.
                self.json = None;
            }
        }
        match &mut self.out {
            Out::Sim(b) => b.write_board(board, outputs).map_err(|e| format!("{e:?}")),
            Out::I2c(b) => b.write_board(board, outputs).map_err(|e| format!("{e:?}")),
        }
    }

    /// A robot with PWM boards: their duties (logged as `orch interpret --json` prints them),
    /// on/off boards' outputs as `write_board`'s.
    fn write_duties(
        &mut self,
        board: BoardId,
        duties: &[orch_core::Duty; 16],
    ) -> Result<(), String> {
        if self.kinds.get(board.index as usize) != Some(&orch_core::BoardKind::Pwm) {
            return self.write_board(board, orch_core::on_off(duties));
        }
        self.writes += 1;
        if let Some(w) = self.json.as_mut() {
            let values: Vec<u16> = duties.iter().map(|d| d.get()).collect();
            let line = json!({"t_us": self.t_us, "byte": self.byte, "address": board.address, "duty": values});
            if writeln!(w, "{line}").is_err() {
                self.json = None;
            }
        }
        match &mut self.out {
            Out::Sim(b) => b.write_duties(board, duties).map_err(|e| format!("{e:?}")),
            Out::I2c(b) => b.write_duties(board, duties).map_err(|e| format!("{e:?}")),
        }
    }
}

impl Tap {
    fn set_time(&mut self, t_us: u64) {
        self.t_us = t_us;
        match &mut self.out {
            Out::Sim(b) => b.set_time(Instant::from_micros(t_us)),
            Out::I2c(b) => b.set_time(Instant::from_micros(t_us)),
        }
    }

    fn flush_log(&mut self) {
        if let Some(w) = self.json.as_mut() {
            if w.flush().is_err() {
                self.json = None;
            }
        }
    }

    /// Housekeeping between writes: lost I2C boards tried again, the virtual robot's
    /// presses counted (and not kept).
    fn poll(&mut self, now_us: u64) {
        match &mut self.out {
            Out::Sim(b) => {
                let mut n = 0;
                b.bus_mut().drain_presses(|_| n += 1);
                self.strikes += n;
            }
            Out::I2c(b) => {
                if !b.lost_now().is_empty() {
                    b.set_time(Instant::from_micros(now_us.max(self.t_us)));
                    b.retry_lost();
                }
            }
        }
    }
}

/// Splits a live byte stream into whole messages for `--thru` and says when the stream is
/// between messages (where the robot's configuration may be swapped).
#[derive(Debug, Default)]
pub struct Framer {
    status: u8,
    data: [u8; 2],
    have: usize,
    sysex: Vec<u8>,
    in_sysex: bool,
    /// The status of the last message sent on (running status, re-encoded).
    sent_status: u8,
}

/// The longest SysEx kept whole for `--thru`; a longer one goes on in pieces.
const SYSEX_CHUNK: usize = 4096;

impl Framer {
    fn need(status: u8) -> usize {
        match status {
            0xC0..=0xDF | 0xF1 | 0xF3 => 1,
            0x80..=0xEF | 0xF2 => 2,
            _ => 0,
        }
    }

    /// The channel status in force (running status), if any.
    pub fn running_status(&self) -> Option<u8> {
        (0x80..=0xEF).contains(&self.status).then_some(self.status)
    }

    /// Forgets a message half received (the input's device went away); the running status
    /// last sent on stays, as the receiver keeps it.
    pub fn forget(&mut self) {
        self.status = 0;
        self.have = 0;
        self.in_sysex = false;
        self.sysex.clear();
    }

    /// Whether no message is half received.
    pub fn idle(&self) -> bool {
        self.have == 0 && !self.in_sysex
    }

    /// Takes one byte; hands every message it completes that `channels` passes to `emit`,
    /// with running status (a channel message whose status is the last one sent goes without
    /// it).
    pub fn push(&mut self, byte: u8, channels: Channels, emit: &mut impl FnMut(&[u8])) {
        match byte {
            0xF8..=0xFF => emit(&[byte]),
            0xF0 => {
                self.status = 0;
                self.have = 0;
                self.in_sysex = true;
                self.sysex.clear();
                self.sysex.push(byte);
                self.sent_status = 0;
            }
            0xF7 if self.in_sysex => {
                self.sysex.push(byte);
                emit(&self.sysex);
                self.sysex.clear();
                self.in_sysex = false;
            }
            0x80..=0xF7 => {
                if self.in_sysex {
                    // A status byte ends a SysEx (MIDI 1.0): what came goes on, closed.
                    self.sysex.push(0xF7);
                    emit(&self.sysex);
                    self.sysex.clear();
                    self.in_sysex = false;
                }
                self.have = 0;
                if byte >= 0xF0 {
                    self.status = 0;
                    self.sent_status = 0;
                    if Self::need(byte) == 0 {
                        emit(&[byte]);
                    } else {
                        self.status = byte;
                    }
                } else {
                    self.status = byte;
                }
            }
            _ if self.in_sysex => {
                self.sysex.push(byte);
                if self.sysex.len() >= SYSEX_CHUNK {
                    emit(&self.sysex);
                    self.sysex.clear();
                }
            }
            _ => {
                let need = Self::need(self.status);
                if need == 0 {
                    return; // no status in force: dropped, as the interpreter drops it
                }
                self.data[self.have] = byte;
                self.have += 1;
                if self.have == need {
                    self.have = 0;
                    let status = self.status;
                    let data = self.data;
                    if status >= 0xF0 {
                        // System common: no running status after it.
                        self.status = 0;
                        let mut m = vec![status];
                        m.extend_from_slice(&data[..need]);
                        emit(&m);
                    } else if channels.passes(&[status]) {
                        if status == self.sent_status {
                            emit(&data[..need]);
                        } else {
                            self.sent_status = status;
                            let mut m = vec![status];
                            m.extend_from_slice(&data[..need]);
                            emit(&m);
                        }
                    }
                }
            }
        }
    }
}

/// A `--thru` output on a thread of its own (a DIN line is written at the wire's pace, which
/// must not hold up the robot).
struct Thru {
    spec: OutSpec,
    framer: Framer,
    tx: Sender<Option<Vec<u8>>>,
    thread: std::thread::JoinHandle<Result<(), String>>,
}

impl Thru {
    fn start(spec: OutSpec, robot: &Robot) -> anyhow::Result<Thru> {
        let mut out = Output::open(&spec.target, &robot.config, &robot.kinds, robot.pwm_hz)
            .map_err(|e| bad_input(format!("--thru {}: {e}", spec.text)))?
            .ok_or_else(|| bad_input("--thru sim: the virtual robot is --out sim"))?;
        let (tx, rx) = mpsc::channel::<Option<Vec<u8>>>();
        let thread = std::thread::Builder::new()
            .name(format!("orch-thru {}", spec.text))
            .spawn(move || -> Result<(), String> {
                let origin = Wall::now();
                let t = || origin.elapsed().as_micros() as u64;
                while let Ok(Some(bytes)) = rx.recv() {
                    out.send(t(), &bytes).map_err(|e| e.to_string())?;
                }
                for m in all_notes_off().chunks(3) {
                    out.send(t(), m).map_err(|e| e.to_string())?;
                }
                out.finish(t()).map_err(|e| e.to_string())
            })?;
        Ok(Thru {
            spec,
            framer: Framer::default(),
            tx,
            thread,
        })
    }

    fn push(&mut self, byte: u8) {
        let (tx, channels) = (&self.tx, self.spec.channels);
        self.framer.push(byte, channels, &mut |m| {
            let _ = tx.send(Some(m.to_vec()));
        });
    }

    /// The input went away: a message half received is forgotten, and All Notes Off goes out
    /// on this output's channels.
    fn line_lost(&mut self) {
        self.framer.forget();
        for m in all_notes_off().chunks(3) {
            if self.spec.channels.passes(m) {
                let _ = self.tx.send(Some(m.to_vec()));
            }
        }
    }

    /// All Notes Off on every channel, then the output is closed.
    fn stop(self) -> anyhow::Result<()> {
        let _ = self.tx.send(None);
        match self.thread.join() {
            Ok(r) => r.map_err(|e| anyhow::anyhow!("--thru {}: {e}", self.spec.text)),
            Err(_) => Err(anyhow::anyhow!(
                "--thru {}: its thread panicked",
                self.spec.text
            )),
        }
    }
}

/// Counters summed over the robot configurations a run went through (SIGHUP reloads).
#[derive(Clone, Copy, Debug, Default)]
struct Totals {
    counters: Counters,
    note_ons: u64,
    sounded: u64,
    dropped: u64,
    cut_by_watchdog: u64,
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

fn init_logging(verbose: bool) {
    let level = if verbose {
        tracing::Level::DEBUG
    } else {
        tracing::Level::WARN
    };
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_max_level(level)
        .with_target(false)
        .try_init();
}

fn open_out(spec: &OutSpec, robot: &Robot) -> anyhow::Result<Out> {
    if spec.channels != Channels::ALL {
        return Err(bad_input(format!(
            "--out {}: the robot takes every channel its robot.toml takes (`channels` there)",
            spec.text
        )));
    }
    match &spec.target {
        Target::Sim => Ok(Out::Sim(Box::new(sim(robot)?))),
        Target::I2c(path) => {
            let bus = open_i2c(&path.to_string_lossy())?;
            let boards: Vec<(u8, orch_core::BoardKind)> = robot.config.layout.boards
                [..robot.boards]
                .iter()
                .zip(&robot.kinds)
                .map(|(b, &kind)| (b.address, kind))
                .collect();
            Ok(Out::I2c(Box::new(ResilientBoards::with_kinds(
                bus,
                &boards,
                robot.pwm_hz,
            )?)))
        }
        _ => Err(bad_input(format!(
            "--out {}: orch run drives finger boards (sim or i2c:DEVICE); a MIDI output goes \
             in --thru",
            spec.text
        ))),
    }
}

fn sim(robot: &Robot) -> anyhow::Result<SimBoards> {
    let config = orch_sim::SimConfig {
        keep: orch_sim::Keep::Presses,
        ..robot.sim_config()
    };
    orch_perform::sim_boards(&config).map_err(|e| anyhow::anyhow!("the virtual robot: {e}"))
}

/// Forwards SIGINT, SIGTERM, SIGHUP and SIGUSR1 into the main loop's channel.
fn forward_signals(tx: Sender<Event>) -> anyhow::Result<signal_hook::iterator::Handle> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM, SIGUSR1};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP, SIGUSR1])?;
    let handle = signals.handle();
    std::thread::Builder::new()
        .name("orch-signals".into())
        .spawn(move || {
            for s in signals.forever() {
                if tx.send(Event::Signal(s)).is_err() {
                    return;
                }
            }
        })?;
    Ok(handle)
}

/// Why the run ended.
enum End {
    Input,
    Signal(i32),
    Quit,
    Failed(anyhow::Error),
}

struct Runner {
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
    robot_path: Option<std::path::PathBuf>,
    /// The input is a DIN line: a read's bytes arrived 320 µs apart.
    din: bool,
    /// The input's name, for messages.
    input_name: String,
    /// Times the input's device went away.
    lost: u64,
    /// Messages cut off by the device going away.
    cut_by_loss: u64,
}

/// One byte on a DIN MIDI line: 10 bits at 31 250 baud.
const DIN_BYTE: Duration = Duration::from_micros(320);

impl Runner {
    fn now_us(&self) -> u64 {
        self.origin
            .map_or(0, |o| o.elapsed().as_micros() as u64)
            .max(self.last_us)
    }

    fn flush(&mut self, t_us: u64, byte: Option<u64>) -> anyhow::Result<()> {
        self.tap.set_time(t_us);
        self.tap.byte = byte;
        let flushed = if self.robot.has_dynamics() {
            self.interp.flush_duties(&mut self.tap)
        } else {
            self.interp.flush(&mut self.tap)
        };
        flushed
            .map_err(|e| anyhow::anyhow!("board {:#04x} failed: {}", e.board.address, e.error))?;
        Ok(())
    }

    /// Runs every timer due at or before `t_us`, each at its own deadline.
    fn timers(&mut self, t_us: u64) -> anyhow::Result<()> {
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

    /// Feeds one read. On a DIN line (`din`) the bytes of a read came in one after the other,
    /// 320 µs apart, the last of them when the read returned: each is fed at that time
    /// (never before the byte fed before it), not all at the time of the read.
    fn bytes(&mut self, at: Wall, bytes: &[u8]) -> anyhow::Result<()> {
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

    /// SIGHUP: reads robot.toml again. The new configuration takes over the first moment
    /// every key is up (none down, waiting to strike or resting before a re-strike) and no
    /// message is half received, so no held key is dropped; a refused file leaves the old
    /// one in force.
    fn reload(&mut self) {
        let Some(path) = self.robot_path.clone() else {
            eprintln!("orch: SIGHUP: no --robot file to read again; the thesis's robot stays");
            return;
        };
        match Robot::load(&path).and_then(|r| r.interpreter().map(|_| r)) {
            Err(e) => eprintln!(
                "orch: SIGHUP: {} refused, the robot stays as it was: {e}",
                path.display()
            ),
            Ok(new) => {
                if matches!(self.tap.out, Out::I2c(_))
                    && new.config.layout.boards[..new.boards]
                        .iter()
                        .map(|b| b.address)
                        .ne(self.robot.config.layout.boards[..self.robot.boards]
                            .iter()
                            .map(|b| b.address))
                {
                    eprintln!(
                        "orch: SIGHUP: {} moves the I2C boards: restart orch run for that; the \
                         robot stays as it was",
                        path.display()
                    );
                    return;
                }
                if new.kinds != self.robot.kinds {
                    eprintln!(
                        "orch: SIGHUP: {} changes the kind of a board (PCA9555, PCA9685): \
                         restart orch run for that; the robot stays as it was",
                        path.display()
                    );
                    return;
                }
                eprintln!(
                    "orch: SIGHUP: {} read; it takes over when no key is down",
                    path.display()
                );
                self.pending = Some(new);
            }
        }
    }

    fn apply_pending(&mut self) -> anyhow::Result<()> {
        if self.pending.is_none() {
            return Ok(());
        }
        // A key's rest before a re-strike ends on a tick: one now (if the stream has begun).
        if self.origin.is_some() {
            let now = self.now_us();
            self.timers(now)?;
            self.interp.tick(Instant::from_micros(now));
            self.flush(now, None)?;
        }
        let keys = self.interp.config().range.keys();
        let all_up = (0..keys).all(|k| self.interp.key_phase(k as u8) == KeyPhase::Up);
        if self.pending.is_none() || !all_up || !self.framer.idle() {
            return Ok(());
        }
        let Some(new) = self.pending.take() else {
            return Ok(());
        };
        let mut interp = new.interpreter()?;
        if let Some(status) = self.framer.running_status() {
            // Running status goes on across the swap.
            interp.feed(status, Instant::from_micros(self.last_us));
        }
        if let Out::Sim(_) = self.tap.out {
            self.tap.out = Out::Sim(Box::new(sim(&new)?));
        }
        self.totals.add(self.interp.counters(), self.interp.stats());
        self.interp = interp;
        self.robot = new;
        eprintln!("orch: the new robot configuration is in force");
        Ok(())
    }

    fn totals(&self) -> Totals {
        let mut t = self.totals;
        t.add(self.interp.counters(), self.interp.stats());
        t
    }

    fn counters_line(&self) -> String {
        let t = self.totals();
        let c = t.counters;
        format!(
            "orch run: {} bytes in {} reads; {} messages; garbage: {} data bytes with no \
             status, {} messages cut short; {} notes: {} sounded, {} dropped; {} keys cut by \
             the watchdog; {} board writes; {} keys down; the input's device went away {} times \
             ({} messages cut off)",
            c.bytes,
            self.reads,
            c.messages,
            c.dropped,
            c.abandoned,
            t.note_ons,
            t.sounded,
            t.dropped,
            t.cut_by_watchdog,
            self.tap.writes,
            self.interp.keys_down(),
            self.lost,
            self.cut_by_loss
        )
    }

    fn scene(&self, title: &str) -> Scene {
        let range = self.interp.config().range;
        Scene {
            command: "orch run",
            title: title.to_string(),
            low_note: range.low().get(),
            down: (0..range.keys())
                .map(|k| self.interp.is_down(k as u8))
                .collect(),
            elapsed_s: self.last_us as f64 / 1e6,
            notes_sent: self.totals().note_ons,
            ..Scene::default()
        }
    }

    /// Every key released on every output.
    /// The input's device went away: a message it cut off is forgotten (the next connection
    /// starts afresh, no running status), every key is released, and the thru outputs get
    /// All Notes Off on their channels (what was held there has lost its Note-Offs too).
    fn line_lost(&mut self) -> anyhow::Result<()> {
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

    fn stop(&mut self) -> anyhow::Result<()> {
        let t = self.now_us();
        self.timers(t)?;
        self.interp.all_off(Instant::from_micros(t));
        self.flush(t, None)?;
        if let Out::I2c(b) = &mut self.tap.out {
            b.release_all();
        }
        Ok(())
    }
}

/// `orch run`.
pub fn run(args: &RunArgs) -> anyhow::Result<()> {
    init_logging(args.verbose);
    let input = InTarget::parse(&args.input).map_err(|e| bad_input(e.to_string()))?;
    let out_spec = OutSpec::parse(&args.out).map_err(|e| bad_input(e.to_string()))?;
    let thru_specs: Vec<OutSpec> = args
        .thru
        .iter()
        .map(|t| {
            OutSpec::parse(t).map_err(|e| bad_input(e.to_string().replacen("--out", "--thru", 1)))
        })
        .collect::<anyhow::Result<_>>()?;
    for t in &thru_specs {
        if matches!(t.target, Target::Sim | Target::I2c(_)) {
            return Err(bad_input(format!(
                "--thru {}: --thru takes MIDI outputs (serial:, rawmidi:, udp:); the robot is --out",
                t.text
            )));
        }
    }
    let robot = crate::play::load_robot(args.robot.as_deref())?;
    let interp = robot.interpreter()?;
    let out = open_out(&out_spec, &robot)?;
    let show = matches!(out, Out::Sim(_))
        && !args.json
        && !args.no_view
        && std::io::stdout().is_terminal();
    let thru = thru_specs
        .into_iter()
        .map(|s| Thru::start(s, &robot))
        .collect::<anyhow::Result<Vec<_>>>()?;

    let (tx, rx) = mpsc::channel::<Event>();
    let signals = forward_signals(tx.clone())?;
    let midi_in =
        MidiIn::open(&input, tx).map_err(|e| bad_input(format!("--in {}: {e}", args.input)))?;
    tracing::debug!(input = midi_in.name(), "reading");

    let kinds = robot.kinds.clone();
    let mut runner = Runner {
        robot,
        interp,
        tap: Tap {
            out,
            json: args.json.then(|| BufWriter::new(std::io::stdout())),
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
        robot_path: args.robot.clone(),
        din: matches!(input, InTarget::Serial(_)),
        input_name: args.input.clone(),
        lost: 0,
        cut_by_loss: 0,
    };
    let priority = orch_perform::realtime::raise_priority();
    tracing::debug!(?priority, "the robot's loop");
    let title = format!("orch run --in {}", args.input);
    let mut view = if show { Some(View::start()?) } else { None };
    let end = main_loop(&mut runner, &rx, args.verbose, view.as_mut(), &title);
    drop(view);
    signals.close();

    let stopped = runner.stop();
    runner.tap.flush_log();
    let mut thru_result = Ok(());
    for t in std::mem::take(&mut runner.thru) {
        if let Err(e) = t.stop() {
            thru_result = Err(e);
        }
    }
    if args.json {
        let layout = &runner.interp.config().layout;
        let list: Vec<_> = layout.boards[..runner.robot.boards]
            .iter()
            .enumerate()
            .map(
                |(i, b)| json!({"address": b.address, "outputs": runner.interp.frame().outputs(i)}),
            )
            .collect();
        if let Some(w) = runner.tap.json.as_mut() {
            let _ = writeln!(w, "{}", json!({"type": "final", "boards": list}));
        }
        runner.tap.flush_log();
    }
    if args.verbose {
        eprintln!("{}", runner.counters_line());
    }
    match &end {
        End::Signal(s) => tracing::debug!(signal = s, "stopped by a signal"),
        End::Input => tracing::debug!("end of input"),
        End::Quit | End::Failed(_) => {}
    }
    stopped?;
    thru_result?;
    match end {
        End::Failed(e) => Err(e),
        End::Input | End::Signal(_) | End::Quit => Ok(()),
    }
}

/// How long the loop waits at most when no timer is due: a live view is drawn 30 times a
/// second; lost I2C boards are tried again.
const IDLE_WAIT: Duration = Duration::from_millis(200);
const VIEW_FRAME: Duration = Duration::from_millis(33);

fn main_loop(
    r: &mut Runner,
    rx: &Receiver<Event>,
    verbose: bool,
    mut view: Option<&mut View>,
    title: &str,
) -> End {
    use signal_hook::consts::{SIGHUP, SIGUSR1};
    let mut last_line = Wall::now();
    let mut activity = false;
    loop {
        let mut wait = if view.is_some() {
            VIEW_FRAME
        } else {
            IDLE_WAIT
        };
        if let (Some(origin), Some(due)) = (r.origin, r.interp.next_deadline()) {
            let at = origin + Duration::from_micros(due.as_micros());
            wait = wait.min(at.saturating_duration_since(Wall::now()));
        }
        let step = match rx.recv_timeout(wait) {
            Ok(Event::In(InEvent::Bytes { at, bytes })) => {
                activity = true;
                r.bytes(at, &bytes)
            }
            Ok(Event::In(InEvent::End)) => return End::Input,
            Ok(Event::In(InEvent::Lost(e))) => {
                eprintln!(
                    "orch: --in {}: the device went away ({e}); every key released; it is \
                     tried again every {} ms",
                    r.input_name,
                    orch_io::RECONNECT_EVERY.as_millis()
                );
                r.line_lost()
            }
            Ok(Event::In(InEvent::Back)) => {
                eprintln!("orch: --in {}: the device is back", r.input_name);
                Ok(())
            }
            Ok(Event::In(InEvent::Failed(e))) => {
                return End::Failed(anyhow::Error::new(e).context("reading the input"))
            }
            Ok(Event::Signal(SIGUSR1)) => {
                eprintln!("{}", r.counters_line());
                Ok(())
            }
            Ok(Event::Signal(SIGHUP)) => {
                r.reload();
                r.apply_pending()
            }
            Ok(Event::Signal(s)) => return End::Signal(s),
            Err(RecvTimeoutError::Timeout) => {
                let now = r.now_us();
                if r.origin.is_some() {
                    r.timers(now).and_then(|()| r.apply_pending())
                } else {
                    r.apply_pending()
                }
            }
            Err(RecvTimeoutError::Disconnected) => return End::Input,
        };
        if let Err(e) = step {
            return End::Failed(e);
        }
        r.tap.flush_log();
        let now = r.now_us();
        r.tap.poll(now);
        if verbose && activity && last_line.elapsed() >= Duration::from_secs(1) {
            eprintln!("{}", r.counters_line());
            last_line = Wall::now();
            activity = false;
        }
        if let Some(v) = view.as_deref_mut() {
            if crate::view::quit_requested() {
                return End::Quit;
            }
            if let Err(e) = v.draw(&r.scene(title)) {
                return End::Failed(anyhow::Error::new(e).context("the live view"));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(bytes: &[u8], channels: Channels) -> Vec<Vec<u8>> {
        let mut f = Framer::default();
        let mut out = Vec::new();
        for &b in bytes {
            f.push(b, channels, &mut |m| out.push(m.to_vec()));
        }
        out
    }

    #[test]
    fn framer_keeps_running_status_and_filters_channels() {
        let all = frame(
            &[0x90, 60, 100, 62, 100, 0xF8, 64, 0, 0x91, 1, 2],
            Channels::ALL,
        );
        assert_eq!(
            all,
            vec![
                vec![0x90, 60, 100],
                vec![62, 100],
                vec![0xF8],
                vec![64, 0],
                vec![0x91, 1, 2]
            ]
        );
        let ch2 = OutSpec::parse("udp:127.0.0.1:9:ch=2").unwrap().channels;
        let some = frame(&[0x90, 60, 100, 0x91, 1, 2, 3, 4, 0x90, 5, 6], ch2);
        assert_eq!(some, vec![vec![0x91, 1, 2], vec![3, 4]]);
        // Stray data bytes go nowhere; a SysEx goes on whole.
        let sx = frame(&[7, 8, 0xF0, 1, 2, 0xF7, 0xC0, 5], Channels::ALL);
        assert_eq!(sx, vec![vec![0xF0, 1, 2, 0xF7], vec![0xC0, 5]]);
    }
}
