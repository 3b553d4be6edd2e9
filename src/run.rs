//! `orch run --in IN --out OUT`: the thesis's ATmega16 job on a Linux host. Live MIDI bytes
//! in (a DIN line through a UART, a raw MIDI device, UDP, standard input), orch-core's
//! interpreter and guard, finger boards out (the virtual robot, or PCA9555 and PCA9685 boards
//! on the host's I2C bus), and the stream passed through to other MIDI outputs (`--thru`).
//!
//! The live interpreter loop's state and steps are `orch-stage`'s ([`LiveRobot`]); here: the
//! arguments, the input and signals, the loop that waits on them with the guard's next
//! deadline as its timeout (so the watchdog lets go of every key when the input goes silent),
//! the messages, the JSON log and the live view.

use std::io::{BufWriter, IsTerminal, Write};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant as Wall};

use orch_io::{InEvent, InTarget, MidiIn, OutSpec, Target};
use orch_stage::thru::Thru;
use orch_stage::{BoardWrite, LiveBoards, LiveError, LiveRobot, ReloadRefused};
use serde_json::json;

use crate::cli::RunArgs;
use crate::error::bad_input;
use crate::robot::Robot;
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

/// The loop's own state beside the live robot: what it says and how it shows it.
struct Runner {
    live: LiveRobot,
    robot_path: Option<std::path::PathBuf>,
    /// The input's name, for messages.
    input_name: String,
    /// The JSON log, shared with the live robot's write log.
    json: Option<Arc<Mutex<BufWriter<std::io::Stdout>>>>,
}

/// A live robot's error as the binary says it: bad input exits 2.
fn live_err(e: LiveError) -> anyhow::Error {
    match e {
        LiveError::BadInput(m) => bad_input(m),
        e => anyhow::Error::new(e),
    }
}

impl Runner {
    fn flush_log(&mut self) {
        if let Some(w) = &self.json {
            if w.lock().unwrap_or_else(|e| e.into_inner()).flush().is_err() {
                // Standard output gone (a closed pipe): the robot plays on without the log.
                self.json = None;
            }
        }
    }

    /// The step's outcome, and the message when a robot read again took over.
    fn step(&mut self, r: Result<(), LiveError>) -> anyhow::Result<()> {
        if self.live.took_over() {
            eprintln!("orch: the new robot configuration is in force");
        }
        r.map_err(live_err)
    }

    /// SIGHUP: reads robot.toml again; it takes over the first moment every key is up and no
    /// message is half received, so no held key is dropped; a refused file leaves the old one
    /// in force.
    fn reload(&mut self) -> anyhow::Result<()> {
        let Some(path) = self.robot_path.clone() else {
            eprintln!("orch: SIGHUP: no --robot file to read again; the thesis's robot stays");
            return Ok(());
        };
        match Robot::load(&path).and_then(|r| r.interpreter().map(|_| r)) {
            Err(e) => eprintln!(
                "orch: SIGHUP: {} refused, the robot stays as it was: {e}",
                path.display()
            ),
            Ok(new) => match self.live.reload(new) {
                Err(ReloadRefused::MovesBoards) => eprintln!(
                    "orch: SIGHUP: {} moves the I2C boards: restart orch run for that; the \
                     robot stays as it was",
                    path.display()
                ),
                Err(ReloadRefused::ChangesKinds) => eprintln!(
                    "orch: SIGHUP: {} changes the kind of a board (PCA9555, PCA9685): restart \
                     orch run for that; the robot stays as it was",
                    path.display()
                ),
                Ok(()) => eprintln!(
                    "orch: SIGHUP: {} read; it takes over when no key is down",
                    path.display()
                ),
            },
        }
        let r = self.live.apply_pending().map(|_| ());
        self.step(r)
    }

    fn counters_line(&self) -> String {
        let t = self.live.totals();
        let c = t.counters;
        let (lost, cut) = self.live.lost();
        format!(
            "orch run: {} bytes in {} reads; {} messages; garbage: {} data bytes with no \
             status, {} messages cut short; {} notes: {} sounded, {} dropped; {} keys cut by \
             the watchdog; {} board writes; {} keys down; the input's device went away {} times \
             ({} messages cut off)",
            c.bytes,
            self.live.reads(),
            c.messages,
            c.dropped,
            c.abandoned,
            t.note_ons,
            t.sounded,
            t.dropped,
            t.cut_by_watchdog,
            self.live.writes(),
            self.live.interpreter().keys_down(),
            lost,
            cut
        )
    }

    fn scene(&self, title: &str) -> Scene {
        let range = self.live.interpreter().config().range;
        Scene {
            command: "orch run",
            title: title.to_string(),
            low_note: range.low().get(),
            down: self.live.keys_down(),
            elapsed_s: self.live.elapsed_s(),
            notes_sent: self.live.totals().note_ons,
            ..Scene::default()
        }
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
    let robot = orch_stage::load_robot(args.robot.as_deref())?;
    robot.interpreter()?;
    let out = LiveBoards::open(&out_spec, &robot).map_err(live_err)?;
    let show = out.is_sim() && !args.json && !args.no_view && std::io::stdout().is_terminal();
    let thru = thru_specs
        .into_iter()
        .map(|s| Thru::start(s, &robot))
        .collect::<Result<Vec<_>, _>>()
        .map_err(live_err)?;

    let (tx, rx) = mpsc::channel::<Event>();
    let signals = forward_signals(tx.clone())?;
    let midi_in =
        MidiIn::open(&input, tx).map_err(|e| bad_input(format!("--in {}: {e}", args.input)))?;
    tracing::debug!(input = midi_in.name(), "reading");

    let json = args
        .json
        .then(|| Arc::new(Mutex::new(BufWriter::new(std::io::stdout()))));
    let log = json.clone().map(|w| {
        Box::new(move |write: &BoardWrite| {
            let mut w = w.lock().unwrap_or_else(|e| e.into_inner());
            // Standard output gone (a closed pipe): the robot plays on without the log.
            let _ = writeln!(w, "{}", orch_stage::writes::json(write));
        }) as Box<dyn FnMut(&BoardWrite) + Send>
    });
    let din = matches!(input, InTarget::Serial(_));
    let live = LiveRobot::new(robot, out, thru, din, log).map_err(live_err)?;
    let mut runner = Runner {
        live,
        robot_path: args.robot.clone(),
        input_name: args.input.clone(),
        json,
    };
    let priority = orch_perform::realtime::raise_priority();
    tracing::debug!(?priority, "the robot's loop");
    let title = format!("orch run --in {}", args.input);
    let mut view = if show { Some(View::start()?) } else { None };
    let end = main_loop(&mut runner, &rx, args.verbose, view.as_mut(), &title);
    drop(view);
    signals.close();

    let stopped = runner.live.stop().map_err(live_err);
    if let Some(w) = &runner.json {
        let list: Vec<_> = runner
            .live
            .outputs()
            .iter()
            .map(|&(address, outputs)| json!({"address": address, "outputs": outputs}))
            .collect();
        let mut w = w.lock().unwrap_or_else(|e| e.into_inner());
        let _ = writeln!(w, "{}", json!({"type": "final", "boards": list}));
    }
    runner.flush_log();
    if args.verbose {
        eprintln!("{}", runner.counters_line());
    }
    match &end {
        End::Signal(s) => tracing::debug!(signal = s, "stopped by a signal"),
        End::Input => tracing::debug!("end of input"),
        End::Quit | End::Failed(_) => {}
    }
    stopped?;
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
        if let Some(at) = r.live.next_deadline() {
            wait = wait.min(at.saturating_duration_since(Wall::now()));
        }
        let step = match rx.recv_timeout(wait) {
            Ok(Event::In(InEvent::Bytes { at, bytes })) => {
                activity = true;
                let step = r.live.bytes(at, &bytes);
                r.step(step)
            }
            Ok(Event::In(InEvent::End)) => return End::Input,
            Ok(Event::In(InEvent::Lost(e))) => {
                eprintln!(
                    "orch: --in {}: the device went away ({e}); every key released; it is \
                     tried again every {} ms",
                    r.input_name,
                    orch_io::RECONNECT_EVERY.as_millis()
                );
                let step = r.live.line_lost();
                r.step(step)
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
            Ok(Event::Signal(SIGHUP)) => r.reload(),
            Ok(Event::Signal(s)) => return End::Signal(s),
            Err(RecvTimeoutError::Timeout) => {
                let step = r.live.tick();
                r.step(step)
            }
            Err(RecvTimeoutError::Disconnected) => return End::Input,
        };
        if let Err(e) = step {
            return End::Failed(e);
        }
        r.flush_log();
        r.live.poll();
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
