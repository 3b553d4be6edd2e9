//! `orch play` and `orch analyze`: a Standard MIDI File performed on the virtual robot by
//! `orch-perform`, and the report.

use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use orch_io::{OutSpec, OutStats, Output, Target};
use orch_perform::{
    perform, song_events, Control, Link, MidiRecording, Outcome, Played, Report, Setup, Spread,
    Tempo,
};
use orch_seq::{Song, VirtualClock};
use orch_stage::session::{lane_events, Lane, Session, SessionFailure, Snapshot};
use serde::Serialize;

use crate::cli::{AnalyzeArgs, PlayArgs};
use crate::error::bad_input;
use crate::robot::Robot;
use crate::view::{note_name, Scene, View};

/// Reads and parses a Standard MIDI File; any damage is bad input (exit 2).
/// The header is checked from the first bytes and the size capped before the file is read
/// ([`crate::input::read_midi_file`]): `orch play /dev/urandom` is refused at once.
pub fn load_song(path: &Path) -> anyhow::Result<Song> {
    let bytes = crate::input::read_midi_file(path)?;
    Song::parse(&bytes).map_err(|e| {
        bad_input(format!(
            "{} is not a playable MIDI file: {e}",
            path.display()
        ))
    })
}

/// Loads the robot for a performance (`play`, `analyze`, `conduct`, `run`).
pub fn load_robot(path: Option<&Path>) -> anyhow::Result<Robot> {
    match path {
        Some(p) => Ok(Robot::load(p)?),
        None => Ok(Robot::thesis()),
    }
}

/// The tempo factors `--tempo` takes: a twentieth to twenty times as written.
const TEMPO_RANGE: std::ops::RangeInclusive<f64> = 0.05..=20.0;

fn tempo(factor: f64) -> anyhow::Result<Tempo> {
    Tempo::new(factor)
        .filter(|t| TEMPO_RANGE.contains(&t.get()))
        .ok_or_else(|| {
            bad_input(format!(
                "--tempo {factor}: give a factor from {} to {}, such as 0.5 or 1.25",
                TEMPO_RANGE.start(),
                TEMPO_RANGE.end()
            ))
        })
}

/// How `robot` plays, with or without compensation, at `tempo`, on this host.
pub fn setup(robot: &Robot, compensation: bool, tempo: Tempo) -> Setup {
    Setup {
        config: robot.config,
        // The report needs the presses and the figures, not every write and edge.
        sim: orch_sim::SimConfig {
            keep: orch_sim::Keep::Presses,
            ..robot.sim_config()
        },
        compensation,
        tempo,
        link: Link::Direct,
    }
}

/// Plays on the virtual clock: as fast as the machine goes.
pub fn render(song: &Song, setup: &Setup) -> anyhow::Result<Played> {
    Ok(perform::<_, MidiRecording>(
        setup,
        song_events(song),
        song.notes(),
        None,
        &mut VirtualClock::new(),
        None,
        None,
    )?)
}

/// The onset error of the same piece without compensation, for comparison.
fn uncompensated(song: &Song, setup: &Setup) -> anyhow::Result<Option<Spread>> {
    if !setup.compensation {
        return Ok(None);
    }
    let plain = Setup {
        compensation: false,
        ..setup.clone()
    };
    Ok(Some(Spread::of_onsets(&render(song, &plain)?.records)))
}

pub fn run_play(args: &PlayArgs) -> anyhow::Result<()> {
    init_logging(args.verbose);
    let song = load_song(&args.file)?;
    let from_us = from_bar(&song, args.from)?;
    let robot = load_robot(args.robot.as_deref())?;
    let mut setup = setup(&robot, !args.no_compensation, tempo(args.tempo)?);
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
    let played: Vec<(OutSpec, Played, Option<OutStats>)> = if args.fast {
        lanes
            .into_iter()
            .map(|l| {
                let (events, notes) = lane_events(&song, l.spec.channels);
                // From a bar: a jump there before the first note.
                let control = from_us.map(|t| {
                    let c = Control::new();
                    c.jump_to(t);
                    c
                });
                let played = perform::<_, Output>(
                    &l.setup,
                    events.into_iter(),
                    notes,
                    None,
                    &mut VirtualClock::new(),
                    control.as_deref(),
                    None,
                )?;
                Ok((l.spec, played, None))
            })
            .collect::<anyhow::Result<_>>()?
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
        write_board_writes(&mut file, &played)
            .with_context(|| format!("--writes {}", path.display()))?;
    }
    if let (Some(mut file), Some(path), Some(song)) = (notes_file, &args.notes, &song_for_notes) {
        let several = played.len() > 1;
        for (spec, p, _) in &played {
            let out = several.then_some(spec.text.as_str());
            write_account(&mut file, song, p, setup.tempo, out)
                .with_context(|| format!("--notes {}", path.display()))?;
        }
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

/// `--notes`: the note-by-note account of `played`, one JSON object a line, in score order
/// (with `"out"` first when several robots played). Bars and beats are the song's own: the
/// tempo factor it was played at is undone.
fn write_account(
    file: &mut impl Write,
    song: &Song,
    played: &Played,
    tempo: Tempo,
    out: Option<&str>,
) -> anyhow::Result<()> {
    let lines = played.account(|t_ms| song.bar_beat((t_ms * 1000.0 * tempo.get()).round() as u64));
    for line in lines {
        let mut value = serde_json::to_value(&line)?;
        if let (Some(out), Some(map)) = (out, value.as_object_mut()) {
            let mut with = serde_json::Map::new();
            with.insert("out".into(), out.into());
            with.extend(std::mem::take(map));
            *map = with;
        }
        writeln!(file, "{value}")?;
    }
    file.flush()?;
    Ok(())
}

/// `--writes`: every robot's board writes, one JSON object a line, robot after robot.
fn write_board_writes(
    file: &mut impl Write,
    played: &[(OutSpec, Played, Option<OutStats>)],
) -> anyhow::Result<()> {
    for (spec, p, _) in played {
        for w in &p.performance.writes {
            // A PCA9685's write: its 16 channels' duties after it (0..=4095); a PCA9555's: the
            // 16 pins it drives.
            let line = match w.duty {
                Some(duty) => serde_json::json!({
                    "out": spec.text,
                    "t_us": w.end.as_micros(),
                    "address": w.address,
                    "duty": duty,
                }),
                None => serde_json::json!({
                    "out": spec.text,
                    "t_us": w.end.as_micros(),
                    "address": w.address,
                    "outputs": w.driven,
                }),
            };
            writeln!(file, "{line}")?;
        }
    }
    file.flush()?;
    Ok(())
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
    bar_start(song, bar).map(Some).ok_or_else(|| {
        bad_input(format!(
            "--from {bar}: the song has bars 1 to {}",
            last_bar(song)
        ))
    })
}

/// The song's last bar (the bar of its last instant).
fn last_bar(song: &Song) -> u32 {
    song.bar_beat(song.duration_us().saturating_sub(1)).0
}

/// Where bar `bar` begins, if the song has it.
fn bar_start(song: &Song, bar: u32) -> Option<u64> {
    (1..=last_bar(song))
        .contains(&bar)
        .then(|| song.bar_start_us(bar))
        .flatten()
}

/// The jump keys of the live view: digits and Enter jump to the bar typed (Backspace takes a
/// digit back), `[` to the bar before the one playing, `]` to the next. Returns the jump's
/// target, µs of score time, if a key asks for one (a bar the song does not have asks for
/// nothing).
pub(crate) fn jump_key(
    key: crate::view::Key,
    typed: &mut String,
    bar_now: u32,
    song: &Song,
) -> Option<u64> {
    use crate::view::Key;
    match key {
        Key::Char(c @ '0'..='9') if typed.len() < 6 => {
            typed.push(c);
            None
        }
        Key::Backspace => {
            typed.pop();
            None
        }
        Key::Enter => {
            let bar = std::mem::take(typed).parse().ok()?;
            bar_start(song, bar)
        }
        Key::Char('[') => bar_start(song, bar_now.saturating_sub(1).max(1)),
        Key::Char(']') => bar_start(song, bar_now.saturating_add(1)),
        _ => None,
    }
}

/// Whether a key is one of the live view's jump keys.
pub(crate) fn is_jump_key(key: crate::view::Key) -> bool {
    use crate::view::Key;
    matches!(
        key,
        Key::Char('0'..='9' | '[' | ']') | Key::Enter | Key::Backspace
    )
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
) -> anyhow::Result<Vec<(OutSpec, Played, Option<OutStats>)>> {
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
    if let Some(t) = from_us {
        control.jump_to(t);
    }
    if lanes.is_empty() {
        return Ok(Vec::new());
    }
    let session = Session::start(song, lanes, Arc::clone(&control), origin);
    let watch = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut view = if show { Some(View::start()?) } else { None };
        let mut view_error = None;
        // The bar being typed, and the bar playing (for `[` and `]`).
        let mut typed = String::new();
        let mut bar_now = 1;
        while !session.is_finished() {
            if signalled.load(Ordering::SeqCst) {
                control.stop();
            }
            if let Some(v) = view.as_mut() {
                let mut on_key = |key: crate::view::Key| {
                    if is_jump_key(key) {
                        if let Some(t) = jump_key(key, &mut typed, bar_now, session.song()) {
                            control.jump_to(t);
                        }
                    } else if let (Some(c), crate::view::Key::Char(ch)) = (conductor.as_mut(), key)
                    {
                        (c.on_key)(ch);
                    }
                };
                // Drawn every 20 ms; a key is taken as it comes.
                if crate::view::keys(Some(&mut on_key), Duration::from_millis(20)) {
                    control.stop();
                }
                if let Some(snapshot) = session.snapshot() {
                    let mut scene = scene(snapshot, &title);
                    bar_now = scene.bar;
                    scene.command = command;
                    scene.prompt = (!typed.is_empty()).then(|| typed.clone());
                    if let Some(c) = &conductor {
                        scene.conductor = Some((c.status)());
                    }
                    if let Err(e) = v.draw(&scene) {
                        view_error = Some(e);
                        control.stop();
                    }
                }
            } else {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        drop(view);
        anyhow::Ok(view_error)
    }));
    if watch.is_err() {
        // The view panicked: stop the robots and let them go before the panic goes on.
        control.stop();
    }
    let finished = session.finish();
    if finished.priority_refused {
        eprintln!(
            "orch: note: the OS refused real-time priority to the sender; under load its \
             messages may be late (see lateness in the report)"
        );
    }
    match watch {
        Err(panic) => std::panic::resume_unwind(panic),
        Ok(Err(e)) => return Err(e),
        Ok(Ok(Some(e))) => return Err(e.into()),
        Ok(Ok(None)) => {}
    }
    if let Some((spec, why)) = finished.failed {
        return Err(match why {
            SessionFailure::Performance(e) => {
                anyhow::Error::new(e).context(format!("--out {}", spec.text))
            }
            SessionFailure::Panicked => anyhow::anyhow!(
                "the sender thread of --out {} panicked (its keys were released)",
                spec.text
            ),
        });
    }
    Ok(finished
        .ended
        .into_iter()
        .map(|e| (e.spec, e.played, e.stats))
        .collect())
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

/// What happened on an output, for the report.
#[derive(Serialize)]
#[serde(untagged)]
enum LinkFigures {
    Port {
        bytes: u64,
        writes: u64,
        lost: u64,
        reconnected: u64,
        dropped_bytes: u64,
    },
    Boards {
        retries: u64,
        failed_writes: u64,
        boards_lost: u64,
        boards_reinitialised: u64,
    },
}

impl From<OutStats> for LinkFigures {
    fn from(s: OutStats) -> Self {
        match s {
            OutStats::Port(p) => LinkFigures::Port {
                bytes: p.bytes,
                writes: p.writes,
                lost: p.lost,
                reconnected: p.reconnected,
                dropped_bytes: p.dropped_bytes,
            },
            OutStats::Boards(b) => LinkFigures::Boards {
                retries: b.retries,
                failed_writes: b.failed_writes,
                boards_lost: b.lost,
                boards_reinitialised: b.reinitialised,
            },
        }
    }
}

impl LinkFigures {
    fn text(&self) -> String {
        match self {
            LinkFigures::Port {
                bytes,
                writes,
                lost,
                reconnected,
                dropped_bytes,
            } => format!(
                "{bytes} bytes in {writes} writes; lost {lost} times, back {reconnected} \
                 times, {dropped_bytes} bytes not sent"
            ),
            LinkFigures::Boards {
                retries,
                failed_writes,
                boards_lost,
                boards_reinitialised,
            } => format!(
                "{failed_writes} failed writes, {retries} retries; boards lost {boards_lost} \
                 times, re-initialised {boards_reinitialised} times"
            ),
        }
    }
}

/// One robot's report: where it played, the channels it took, its output's figures.
#[derive(Serialize)]
struct RobotReport<'a> {
    out: &'a str,
    channels: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    link: Option<LinkFigures>,
    #[serde(flatten)]
    report: Report,
}

pub(crate) fn print_reports(
    played: &[(OutSpec, Played, Option<OutStats>)],
    json: bool,
    file: &Path,
    named: bool,
) -> anyhow::Result<()> {
    if !named {
        if let [(_, p, _)] = played {
            return print_report(&p.report(None), json, file);
        }
    }
    let robots: Vec<RobotReport> = played
        .iter()
        .map(|(spec, p, stats)| RobotReport {
            out: &spec.text,
            channels: spec.channels.to_string(),
            link: stats.map(LinkFigures::from),
            report: p.report(None),
        })
        .collect();
    for r in &robots {
        if let Some(LinkFigures::Port { lost, .. }) = r.link {
            if lost > 0 {
                eprintln!(
                    "orch: --out {}: the device went away {lost} times during the performance",
                    r.out
                );
            }
        }
    }
    let mut out = std::io::stdout().lock();
    if json {
        if let [one] = robots.as_slice() {
            writeln!(out, "{}", serde_json::to_string(one)?)?;
        } else {
            writeln!(
                out,
                "{}",
                serde_json::to_string(&serde_json::json!({ "robots": robots }))?
            )?;
        }
        return Ok(());
    }
    writeln!(out, "{}", file.display())?;
    for (i, r) in robots.iter().enumerate() {
        writeln!(out)?;
        writeln!(
            out,
            "robot {}: {} (channels {})",
            i + 1,
            r.out,
            if r.channels.split(',').count() == 16 {
                "all".to_string()
            } else {
                r.channels.clone()
            }
        )?;
        if let Some(l) = &r.link {
            writeln!(out, "  output: {}", l.text())?;
        }
        write!(out, "{}", r.report.text())?;
    }
    Ok(())
}

fn print_report(report: &Report, json: bool, file: &Path) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    if json {
        writeln!(out, "{}", serde_json::to_string(report)?)?;
    } else {
        writeln!(out, "{}", file.display())?;
        write!(out, "{}", report.text())?;
    }
    Ok(())
}

/// A note that will go wrong, for `orch analyze`.
#[derive(Debug, Serialize)]
pub struct Wrong {
    pub bar: u32,
    pub beat: u32,
    /// The note's name as written ("C4" for 60).
    pub note: String,
    /// 1..=16, as people count channels.
    pub channel: u8,
    /// late, early, joined, unmatched, the drop's reason (`too_soft` among them: no sound),
    /// or, for a note struck on time on a PWM key, `louder` or `softer` (than its velocity, by
    /// more than 2 steps).
    pub outcome: &'static str,
    /// How late or early, ms (late and early only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ms: Option<f64>,
    /// Its velocity in the file, and how loud it sounded on the velocity scale (`louder` and
    /// `softer` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sounded_velocity: Option<u8>,
}

/// The notes that will go wrong, the worst first. Bars and beats are the song's own: the
/// tempo factor it was played at is undone.
pub fn went_wrong(song: &Song, played: &Played, tempo: Tempo) -> Vec<Wrong> {
    played
        .went_wrong()
        .into_iter()
        .map(|r| {
            let wall = (r.score_at_us - played.start_us as i64).max(0) as f64;
            let (bar, beat) = song.bar_beat((wall * tempo.get()).round() as u64);
            let loudness = match r.outcome {
                Outcome::OnTime { .. } => played.loudness_off(r),
                _ => None,
            };
            Wrong {
                bar,
                beat,
                note: note_name(r.note),
                channel: r.channel + 1,
                outcome: match loudness {
                    Some(true) => "louder",
                    Some(false) => "softer",
                    None => r.outcome.name(),
                },
                velocity: loudness.map(|_| r.velocity),
                sounded_velocity: loudness.and(r.sounded_velocity),
                ms: match r.outcome {
                    Outcome::Late { by_us } | Outcome::Early { by_us } => {
                        Some(by_us as f64 / 1000.0)
                    }
                    _ => None,
                },
            }
        })
        .collect()
}

#[derive(Serialize)]
struct Analysis<'a> {
    #[serde(flatten)]
    report: &'a Report,
    went_wrong: &'a [Wrong],
}

pub fn run_analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    let song = load_song(&args.file)?;
    let robot = load_robot(args.robot.as_deref())?;
    let mut setup = setup(&robot, true, tempo(args.tempo)?);
    let svg_file = create(&args.svg, "--svg")?;
    if svg_file.is_some() {
        // The roll draws each strike to its key-up: the sound events are kept too.
        setup.sim.keep = orch_sim::Keep::Everything;
    }
    let played = render(&song, &setup)?;
    if let (Some(mut file), Some(path)) = (svg_file, &args.svg) {
        crate::roll::write(&mut file, &args.file, &song, &robot, &played, setup.tempo)
            .with_context(|| format!("--svg {}", path.display()))?;
    }
    let report = played.report(uncompensated(&song, &setup)?);
    let wrong = went_wrong(&song, &played, setup.tempo);
    if let Some(mut file) = create(&args.notes, "--notes")? {
        write_account(&mut file, &song, &played, setup.tempo, None).with_context(|| {
            format!(
                "--notes {}",
                args.notes
                    .as_ref()
                    .map_or(String::new(), |p| p.display().to_string())
            )
        })?;
    }
    let mut out = std::io::stdout().lock();
    if args.json {
        let a = Analysis {
            report: &report,
            went_wrong: &wrong,
        };
        writeln!(out, "{}", serde_json::to_string(&a)?)?;
        return Ok(());
    }
    writeln!(out, "{}", args.file.display())?;
    for finding in findings(&song, &robot, &report) {
        writeln!(out, "- {finding}")?;
    }
    if !wrong.is_empty() {
        writeln!(out)?;
        writeln!(out, "notes that will go wrong, the worst first:")?;
        for w in wrong.iter().take(LISTED) {
            let amount = match (w.ms, w.velocity, w.sounded_velocity) {
                (Some(ms), _, _) => format!(" by {ms:.1} ms"),
                (None, Some(v), Some(heard)) => {
                    format!(" than asked: velocity {v}, sounds as {heard}")
                }
                _ => String::new(),
            };
            writeln!(
                out,
                "  {:>4}:{:<2} {:<4} ch {:<2} {}{}",
                w.bar, w.beat, w.note, w.channel, w.outcome, amount
            )?;
        }
        if wrong.len() > LISTED {
            writeln!(
                out,
                "  … and {} more (--json lists them all)",
                wrong.len() - LISTED
            )?;
        }
    }
    writeln!(out)?;
    write!(out, "{}", report.text())?;
    Ok(())
}

/// Notes `orch analyze` lists in text.
const LISTED: usize = 20;

/// What will go wrong, in words.
pub(crate) fn findings(song: &Song, robot: &Robot, r: &Report) -> Vec<String> {
    let mut f = Vec::new();
    if !robot.config.guard.enabled {
        f.push(
            "WARNING: the safety guard is OFF in this robot.toml: no hold limit, duty limit, \
             power budget or watchdog protects the solenoids. Never play a robot like this."
                .into(),
        );
    }
    if r.notes == 0 {
        f.push("the file has no notes to play".into());
        return f;
    }
    let o = &r.outcomes;
    let share = |n: u64| 100.0 * n as f64 / r.notes.max(1) as f64;
    let heard = o.on_time + o.late + o.early + o.unison;
    f.push(format!(
        "{} of {} notes ({:.1}%) will sound: {} on time, {} late, {} in unison; {:.3} s long",
        heard,
        r.notes,
        share(heard),
        o.on_time,
        o.late,
        o.unison,
        song.duration_us() as f64 / 1e6
    ));
    let d = &o.dropped;
    let budget = robot.config.guard.max_keys_down;
    let counted: [(u64, String); 14] = [
        (
            o.joined,
            "notes land on a key already down for another note and make no sound of their own"
                .into(),
        ),
        (
            r.folded,
            "notes are outside the keys and will be folded by octaves".into(),
        ),
        (
            d.range,
            "notes are outside the keys and will not be played".into(),
        ),
        (
            d.channel,
            "notes are on channels the robot does not listen to".into(),
        ),
        (
            d.power,
            format!(
                "notes would pass the power budget of {budget} keys at once and will be refused"
            ),
        ),
        (
            d.too_fast,
            "notes repeat a key too fast to strike it again within the late limit and will be dropped"
                .into(),
        ),
        (
            r.cut_by_hold_limit,
            "keys are held past the hold limit and will be cut short".into(),
        ),
        (
            r.cut_by_duty_limit,
            "keys are energised past the duty limit and will be cut".into(),
        ),
        (
            r.unmatched,
            "notes strike but are too short for the key to sound".into(),
        ),
        (
            r.smeared,
            "presses come before the key is back up and will smear".into(),
        ),
        (
            d.cancelled,
            "re-strikes waiting for their key's rest will be cancelled".into(),
        ),
        (
            d.too_soft,
            "notes will strike too softly to sound (below the key's softest duty: raise \
             dynamics.softest, or lower mechanics.softest if the keys sound softer than that)"
                .into(),
        ),
        (
            r.velocity_error.map_or(0, |v| v.softer),
            "notes will sound softer than their velocity by more than 2 steps (robot.toml's \
             [dynamics] curve is below what the keys need)"
                .into(),
        ),
        (
            r.velocity_error.map_or(0, |v| v.louder),
            "notes will sound louder than their velocity by more than 2 steps (robot.toml's \
             [dynamics] curve is above what the keys need)"
                .into(),
        ),
    ];
    f.extend(
        counted
            .iter()
            .filter(|(n, _)| *n > 0)
            .map(|(n, what)| format!("{n} {what}")),
    );
    let drums = song
        .events()
        .iter()
        .filter(|e| e.bytes.note_on().is_some_and(|(ch, _, _)| ch == 9))
        .count();
    let ten = orch_core::Channel::new(9).expect("channel 10");
    if drums > 0 && robot.config.channels.contains(ten) {
        f.push(format!(
            "{drums} notes are drums on channel 10: a piano plays them as pitches; \
             consider `channels` in robot.toml"
        ));
    }
    if f.len() == 1 {
        f.push("nothing will go wrong".into());
    }
    f
}
