//! `orch play` and `orch analyze`: a Standard MIDI File performed on the virtual robot by
//! `orch-perform`, and the report.

use std::io::{IsTerminal, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use orch_perform::{
    perform, realtime, song_events, Control, Link, Live, MidiRecording, Outcome, Played, Report,
    Setup, Spread, Tempo,
};
use orch_seq::{Song, VirtualClock};
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
    let song = load_song(&args.file)?;
    let robot = load_robot(args.robot.as_deref())?;
    let setup = setup(&robot, !args.no_compensation, tempo(args.tempo)?);
    let played = if args.fast {
        render(&song, &setup)?
    } else {
        play_live(song.clone(), &setup, args)?
    };
    // The comparison without compensation is `orch analyze`'s: a play renders once.
    let report = played.report(None);
    print_report(&report, args.json, &args.file)
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

/// Plays in real time: the sender on its own thread (real-time priority where allowed), the
/// view on this one. `q`, SIGINT, SIGTERM and SIGHUP stop it with every key released, and the
/// report still comes.
fn play_live(song: Song, setup: &Setup, args: &PlayArgs) -> anyhow::Result<Played> {
    let signalled = stop_on_signals()?;
    let show = !args.no_view && std::io::stdout().is_terminal();
    let title = args
        .file
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let control = Control::new();
    let live: Arc<Mutex<Option<Live>>> = Arc::new(Mutex::new(None));
    let song = Arc::new(song);
    let sender = {
        let (setup, control, live, song) = (
            setup.clone(),
            Arc::clone(&control),
            Arc::clone(&live),
            Arc::clone(&song),
        );
        realtime::spawn(move || {
            let mut clock = realtime::PreciseClock::new();
            let mut on_live = |l: &Live| {
                *live.lock().unwrap_or_else(|e| e.into_inner()) = Some(l.clone());
            };
            perform::<_, MidiRecording>(
                &setup,
                song_events(&song),
                song.notes(),
                None,
                &mut clock,
                Some(&control),
                Some(&mut on_live),
            )
        })
    };
    let mut view = if show { Some(View::start()?) } else { None };
    let low = setup.config.range.low().get();
    let total_s = song.duration_us() as f64 / 1e6 / setup.tempo.get();
    let mut view_error = None;
    while !sender.is_finished() {
        if signalled.load(Ordering::SeqCst) {
            control.stop();
        }
        if let Some(v) = view.as_mut() {
            if crate::view::quit_requested() {
                control.stop();
            }
            let snapshot = live.lock().unwrap_or_else(|e| e.into_inner()).clone();
            if let Some(l) = snapshot {
                let (bar, beat) = song.bar_beat(l.song_us);
                let scene = Scene {
                    title: title.clone(),
                    low_note: low,
                    down: l.keys_down,
                    bar,
                    beat,
                    bpm: song.tempo_at(l.song_us).bpm() * l.tempo,
                    elapsed_s: l.song_us as f64 / 1e6 / l.tempo,
                    total_s,
                    notes_sent: l.notes_sent,
                    notes: song.notes() as u64,
                };
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
    let (priority, played) = sender
        .join()
        .map_err(|_| anyhow::anyhow!("the sender thread panicked"))?;
    if priority != realtime::Priority::Realtime {
        eprintln!(
            "orch: note: the OS refused real-time priority to the sender ({priority:?}); \
             under load its messages may be late (see lateness in the report)"
        );
    }
    if let Some(e) = view_error {
        return Err(e.into());
    }
    Ok(played?)
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
    /// late, early, joined, unmatched, or the drop's reason.
    pub outcome: &'static str,
    /// How late or early, ms (late and early only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ms: Option<f64>,
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
            Wrong {
                bar,
                beat,
                note: note_name(r.note),
                channel: r.channel + 1,
                outcome: r.outcome.name(),
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
    let setup = setup(&robot, true, tempo(args.tempo)?);
    let played = render(&song, &setup)?;
    let report = played.report(uncompensated(&song, &setup)?);
    let wrong = went_wrong(&song, &played, setup.tempo);
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
            let amount = w.ms.map_or(String::new(), |ms| format!(" by {ms:.1} ms"));
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
fn findings(song: &Song, robot: &Robot, r: &Report) -> Vec<String> {
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
    let counted: [(u64, String); 11] = [
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
