//! `orch run --in IN --out OUT`: the thesis's ATmega16 job on a Linux host. Live MIDI bytes
//! in (a DIN line through a UART, a raw MIDI device, UDP, an RTP-MIDI session, standard
//! input), orch-core's
//! interpreter and guard, finger boards out (the virtual robot, or PCA9555 and PCA9685 boards
//! on the host's I2C bus), and the stream passed through to other MIDI outputs (`--thru`).
//!
//! The live robot and its loop are `orch-stage`'s ([`LiveRobot`], [`orch_stage::run`]); here:
//! the arguments, the signals, the messages, the JSON log and the live view.

use std::io::{BufWriter, IsTerminal};
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;

use orch_io::{InTarget, MidiIn, OutSpec};
use orch_stage::run::{counters, end_state, End, Event, Loop, Said};
use orch_stage::session::Snapshot;
use orch_stage::thru::Thru;
use orch_stage::writes::JsonLog;
use orch_stage::{LiveBoards, LiveRobot};

use crate::cli::RunArgs;
use crate::error::{bad_input, live as live_err};
use crate::view::{Scene, View};

/// What the loop says, on standard error, headed by what it is about.
fn say(said: Said, input: &str) {
    match said {
        Said::Counters(_) => eprintln!("orch run: {said}"),
        Said::Lost(_) | Said::Back | Said::Joined(_) | Said::Left(_) => {
            eprintln!("orch: --in {input}: {said}")
        }
        Said::TookOver => eprintln!("orch: {said}"),
        _ => eprintln!("orch: SIGHUP: {said}"),
    }
}

/// What the view shows of the live robot.
fn scene(live: &LiveRobot, title: &str) -> Scene {
    Scene {
        command: "orch run",
        title: title.to_string(),
        now: Snapshot {
            low_note: live.interpreter().config().range.low().get(),
            keys_down: live.keys_down(),
            elapsed_s: live.elapsed_s(),
            notes_sent: live.totals().note_ons,
            ..Snapshot::default()
        },
        ..Scene::default()
    }
}

/// `orch run`.
pub fn run(args: &RunArgs) -> anyhow::Result<()> {
    crate::live::init_logging(args.verbose);
    let input = InTarget::parse(&args.input).map_err(|e| bad_input(e.to_string()))?;
    let out_spec = OutSpec::parse(&args.out).map_err(|e| bad_input(e.to_string()))?;
    let thru_specs = orch_stage::thru::specs(&args.thru).map_err(live_err)?;
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
    let stopped_by = Arc::new(AtomicI32::new(0));
    let signals = orch_stage::signals::forward(tx.clone(), Arc::clone(&stopped_by))?;
    let midi_in =
        MidiIn::open(&input, tx).map_err(|e| bad_input(format!("--in {}: {e}", args.input)))?;
    tracing::debug!(input = midi_in.name(), "reading");

    // The JSON log on standard output, shared with the live robot's write log.
    let mut json = JsonLog::to(args.json.then(|| BufWriter::new(std::io::stdout())));
    let log = json.sink();
    let din = matches!(input, InTarget::Serial(_));
    let mut live = LiveRobot::new(robot, out, thru, din, log).map_err(live_err)?;
    let priority = orch_perform::realtime::raise_priority();
    tracing::debug!(?priority, "the robot's loop");
    let title = format!("orch run --in {}", args.input);
    let mut view = if show { Some(View::start()?) } else { None };
    let end = {
        // The view is drawn 30 times a second; without it the loop wakes every 200 ms at
        // least (lost I2C boards are tried again).
        let every = Duration::from_millis(if view.is_some() { 33 } else { 200 });
        let mut after = |live: &LiveRobot| {
            json.flush();
            let v = view.as_mut()?;
            if crate::view::quit_requested() {
                return Some(End::Quit);
            }
            let drawn = v.draw(&scene(live, &title));
            drawn.err().map(|e| End::Front(Box::new(e)))
        };
        Loop {
            robot_path: args.robot.clone(),
            every,
            verbose: args.verbose,
            say: &mut |s| say(s, &args.input),
            after: &mut after,
        }
        .run(&mut live, &rx)
    };
    drop(view);
    signals.close();

    let stopped = live.stop().map_err(live_err);
    json.finish(&end_state(&live));
    if args.verbose {
        eprintln!("orch run: {}", counters(&live));
    }
    match &end {
        End::Stopped => {
            let signal = stopped_by.load(Ordering::SeqCst);
            tracing::debug!(signal, "stopped by a signal");
        }
        End::Input => tracing::debug!("end of input"),
        _ => {}
    }
    stopped?;
    match end {
        End::Input | End::Stopped | End::Quit => Ok(()),
        End::InputFailed(e) => Err(anyhow::Error::new(e).context("reading the input")),
        End::Failed(e) => Err(live_err(e)),
        End::Front(e) => Err(anyhow::anyhow!(e).context("the live view")),
    }
}
