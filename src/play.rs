//! `orch play` and `orch analyze`: a Standard MIDI File performed on the virtual robot (or
//! the robots `--out` names), and the report. The work is `orch-stage`'s (loading, setting
//! up, playing, the report, the analysis, the account); here: the arguments, the live view's
//! loop, the files and the printing.

use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use orch_io::{OutSpec, Target};
use orch_perform::{Control, Setup, Tempo};
use orch_seq::Song;
use orch_stage::session::{Ended, Lane, Session, SessionFailure, Snapshot};
use orch_stage::watch::{self, WatchError};
use orch_stage::{analyze, bars, load_robot, load_song, text, Reports};

use crate::cli::{AnalyzeArgs, PlayArgs};
use crate::error::bad_input;
use crate::view::{Key, Scene, View};

/// `--tempo`: the factor, if a session takes it.
fn tempo(factor: f64) -> anyhow::Result<Tempo> {
    orch_stage::setup::tempo(factor).with_context(|| format!("--tempo {factor}"))
}

pub fn run_play(args: &PlayArgs) -> anyhow::Result<()> {
    init_logging(args.verbose);
    let song = load_song(&args.file)?;
    let from_us = from_bar(&song, args.from)?;
    let robot = load_robot(args.robot.as_deref())?;
    let mut setup = orch_stage::setup::setup(&robot, !args.no_compensation, tempo(args.tempo)?);
    if args.writes.is_some() {
        // Every write is kept for the file, not only the presses the report needs.
        setup.sim.keep = orch_sim::Keep::Everything;
    }
    let writes = create(&args.writes, "--writes")?;
    let notes_file = create(&args.notes, "--notes")?;
    // The song is kept for the account's bars and beats (a live play takes it).
    let song_for_notes = args.notes.is_some().then(|| song.clone());
    let specs = out_specs(&args.outs)?;
    if args.fast {
        if let Some(s) = specs.iter().find(|s| s.target != Target::Sim) {
            return Err(bad_input(format!(
                "--fast renders on the virtual clock, as fast as the machine goes: it cannot \
                 play --out {}; leave out --fast",
                s.text
            )));
        }
    }
    let lanes = open_lanes(specs, &setup)?;
    let played = if args.fast {
        orch_stage::setup::play_lanes_fast(&song, lanes, from_us)?
    } else {
        let live = LiveOptions {
            command: "orch play",
            view: !args.no_view,
            file: &args.file,
            from_us,
            conductor: None,
        };
        play_live(song, lanes, live)?
    };
    if let (Some(mut file), Some(path)) = (writes, &args.writes) {
        orch_stage::account::write_board_writes(&mut file, &played)
            .with_context(|| format!("--writes {}", path.display()))?;
    }
    if let (Some(mut file), Some(path), Some(song)) = (notes_file, &args.notes, &song_for_notes) {
        orch_stage::account::write_accounts(&mut file, song, &played, setup.tempo)
            .with_context(|| format!("--notes {}", path.display()))?;
    }
    // The comparison without compensation is `orch analyze`'s: a play renders once.
    print_reports(&played, args.json, &args.file, !args.outs.is_empty())
}

/// Creates the file an option names, if it names one.
fn create(path: &Option<PathBuf>, option: &str) -> anyhow::Result<Option<BufWriter<File>>> {
    match path {
        Some(path) => {
            Ok(Some(BufWriter::new(File::create(path).map_err(|e| {
                bad_input(format!("{option} {}: {e}", path.display()))
            })?)))
        }
        None => Ok(None),
    }
}

/// Opens every output: one robot (a lane) each; a bad output is bad input (exit 2).
pub(crate) fn open_lanes(specs: Vec<OutSpec>, setup: &Setup) -> anyhow::Result<Vec<Lane>> {
    orch_stage::session::open_lanes(specs, setup).map_err(|e| match e {
        orch_stage::LiveError::BadInput(m) => bad_input(m),
        e => anyhow::Error::new(e),
    })
}

/// `--from BAR`: where bar `bar` begins, µs of score time; bad input (exit 2) for a bar the
/// song does not have.
pub(crate) fn from_bar(song: &Song, bar: Option<u32>) -> anyhow::Result<Option<u64>> {
    let Some(bar) = bar else {
        return Ok(None);
    };
    let start = orch_stage::bars::start_of(song, bar).with_context(|| format!("--from {bar}"))?;
    Ok(Some(start))
}

/// How a live performance is shown and steered.
pub(crate) struct LiveOptions<'a> {
    /// The command that runs, for the view's head.
    pub command: &'static str,
    /// `--from`: start at this score time (µs), a jump before the first note.
    pub from_us: Option<u64>,
    /// The live view, if standard output is a terminal.
    pub view: bool,
    /// The file played (its name is the view's title).
    pub file: &'a Path,
    /// A conductor (`orch conduct`), steering the performance through its own control.
    pub conductor: Option<Conductor<'a>>,
}

/// A conductor steering a live performance.
pub(crate) struct Conductor<'a> {
    /// The control the conductor steers; the performance's.
    pub control: Arc<Control>,
    /// The performer's clock's zero (the conductor's cues are timed on it).
    pub origin: std::time::Instant,
    /// The line the view shows under its head: the conductor's beats and tempo.
    pub status: &'a dyn Fn() -> String,
    /// A key pressed in the view (other than q and Esc).
    pub on_key: &'a mut dyn FnMut(char),
}

/// Logging through `tracing` on standard error: warnings (a device or a board lost, and back),
/// everything the outputs do with `--verbose`.
pub(crate) fn init_logging(verbose: bool) {
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

/// The `--out` options; the virtual robot alone when there is none.
pub(crate) fn out_specs(outs: &[String]) -> anyhow::Result<Vec<OutSpec>> {
    if outs.is_empty() {
        return Ok(vec![OutSpec::parse("sim").expect("sim is an output")]);
    }
    outs.iter()
        .map(|o| OutSpec::parse(o).map_err(|e| bad_input(e.to_string())))
        .collect()
}

/// Set by SIGINT, SIGTERM and SIGHUP: stop the way `q` does.
fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    for sig in [
        signal_hook::consts::SIGINT,
        signal_hook::consts::SIGTERM,
        signal_hook::consts::SIGHUP,
    ] {
        signal_hook::flag::register(sig, Arc::clone(&flag))?;
    }
    Ok(flag)
}

/// Plays in real time: one sender thread per robot (real-time priority where allowed), all on
/// one clock, the view on this thread. `q`, SIGINT, SIGTERM and SIGHUP stop every robot with
/// every key released, and the reports still come; so does a panic, on any thread.
pub(crate) fn play_live(
    song: Song,
    lanes: Vec<Lane>,
    options: LiveOptions<'_>,
) -> anyhow::Result<Vec<Ended>> {
    let LiveOptions {
        command,
        from_us,
        view: show,
        file,
        mut conductor,
    } = options;
    let signalled = stop_on_signals()?;
    let show = show && std::io::stdout().is_terminal();
    let title = file
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let (control, origin) = match &conductor {
        Some(c) => (Arc::clone(&c.control), c.origin),
        None => (Control::new(), std::time::Instant::now()),
    };
    let mut view = None;
    // The bar being typed, and the bar playing (for `[` and `]`).
    let mut typed = bars::Typed::default();
    let mut bar_now = 1;
    let watch = |session: &Session| -> anyhow::Result<()> {
        let control = session.control();
        if signalled.load(Ordering::SeqCst) {
            control.stop();
        }
        if !show {
            std::thread::sleep(Duration::from_millis(20));
            return Ok(());
        }
        if view.is_none() {
            view = Some(View::start()?);
        }
        // The jump keys: digits and Enter go to the bar typed (Backspace takes a digit back),
        // `[` to the bar before the one playing, `]` to the next.
        let mut on_key = |key: Key| {
            let song = session.song();
            let jump = match key {
                Key::Char(c @ '0'..='9') => {
                    typed.digit(c);
                    None
                }
                Key::Backspace => {
                    typed.back();
                    None
                }
                Key::Enter => typed.enter(song),
                Key::Char('[') => bars::before(song, bar_now),
                Key::Char(']') => bars::after(song, bar_now),
                Key::Char(c) => {
                    if let Some(k) = conductor.as_mut() {
                        (k.on_key)(c);
                    }
                    None
                }
            };
            if let Some(t) = jump {
                control.jump_to(t);
            }
        };
        // Drawn every 20 ms; a key is taken as it comes.
        if crate::view::keys(Some(&mut on_key), Duration::from_millis(20)) {
            control.stop();
        }
        let Some(snapshot) = session.snapshot() else {
            return Ok(());
        };
        let mut scene = scene(snapshot, &title);
        bar_now = scene.bar;
        scene.command = command;
        scene.prompt = typed.shown().map(str::to_string);
        scene.conductor = conductor.as_ref().map(|c| (c.status)());
        Ok(view.as_mut().expect("started").draw(&scene)?)
    };
    let watched = watch::play(song, lanes, control, origin, from_us, watch);
    // The terminal is given back before anything is said.
    drop(view);
    if watched.priority_refused {
        eprintln!(
            "orch: note: the OS refused real-time priority to the sender; under load its \
             messages may be late (see lateness in the report)"
        );
    }
    watched.result.map_err(|e| match e {
        WatchError::Panicked(panic) => std::panic::resume_unwind(panic),
        WatchError::Front(e) => e,
        WatchError::Failed(spec, SessionFailure::Performance(e)) => {
            anyhow::Error::new(e).context(format!("--out {}", spec.text))
        }
        WatchError::Failed(spec, SessionFailure::Panicked) => anyhow::anyhow!(
            "the sender thread of --out {} panicked (its keys were released)",
            spec.text
        ),
    })
}

/// What the view shows of a session's snapshot.
fn scene(s: Snapshot, title: &str) -> Scene {
    Scene {
        title: title.to_string(),
        low_note: s.low_note,
        down: s.keys_down,
        bar: s.bar,
        beat: s.beat,
        bpm: s.bpm,
        elapsed_s: s.elapsed_s,
        total_s: s.total_s,
        notes_sent: s.notes_sent,
        notes: s.notes,
        ..Scene::default()
    }
}

/// Prints every robot's report (JSON or text); says on standard error when an output's
/// device went away during the performance.
pub(crate) fn print_reports(
    played: &[Ended],
    json: bool,
    file: &Path,
    named: bool,
) -> anyhow::Result<()> {
    let reports = Reports::of(played, named);
    if let Reports::Robots(robots) = &reports {
        for r in robots.iter().filter(|r| r.times_lost() > 0) {
            eprintln!(
                "orch: --out {}: the device went away {} times during the performance",
                r.out,
                r.times_lost()
            );
        }
    }
    let mut out = std::io::stdout().lock();
    if json {
        writeln!(out, "{}", serde_json::to_string(&reports)?)?;
    } else {
        write!(out, "{}", text::reports(&reports, file))?;
    }
    Ok(())
}

pub fn run_analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    let song = load_song(&args.file)?;
    let robot = load_robot(args.robot.as_deref())?;
    let mut setup = orch_stage::setup::setup(&robot, true, tempo(args.tempo)?);
    let svg_file = create(&args.svg, "--svg")?;
    if svg_file.is_some() {
        // The roll draws each strike to its key-up: the sound events are kept too.
        setup.sim.keep = orch_sim::Keep::Everything;
    }
    let (analysis, played) = analyze(&song, &robot, &setup)?;
    if let (Some(mut file), Some(path)) = (svg_file, &args.svg) {
        let title = args.file.file_name().map_or_else(
            || args.file.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        orch_stage::analysis::roll_svg(&song, &robot, &played, setup.tempo, &title)
            .map_err(anyhow::Error::new)
            .and_then(|svg| Ok(file.write_all(svg.as_bytes()).and_then(|()| file.flush())?))
            .with_context(|| format!("--svg {}", path.display()))?;
    }
    if let (Some(mut file), Some(path)) = (create(&args.notes, "--notes")?, &args.notes) {
        orch_stage::account::write_account(&mut file, &song, &played, setup.tempo, None)
            .with_context(|| format!("--notes {}", path.display()))?;
    }
    let mut out = std::io::stdout().lock();
    if args.json {
        // `orch analyze --json` has the report's fields and the notes that went wrong; the
        // findings are its text's.
        let mut value = serde_json::to_value(&analysis)?;
        if let Some(map) = value.as_object_mut() {
            map.remove("findings");
        }
        writeln!(out, "{value}")?;
    } else {
        write!(out, "{}", text::analysis(&analysis, &args.file))?;
    }
    Ok(())
}
