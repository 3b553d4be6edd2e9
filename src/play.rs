//! `orch play` and `orch analyze`: a Standard MIDI File on the virtual robot, and the report.

use std::io::{IsTerminal, Write};
use std::path::Path;

use orch_seq::{RealClock, Song, TempoScale};

use crate::cli::{AnalyzeArgs, PlayArgs};
use crate::error::bad_input;
use crate::perform::{perform, Options, Outcome};
use crate::report::Report;
use crate::robot::Robot;
use crate::view::{Scene, View};

/// Reads and parses a Standard MIDI File; any damage is bad input (exit 2).
pub fn load_song(path: &Path) -> anyhow::Result<Song> {
    let bytes = std::fs::read(path)
        .map_err(|e| bad_input(format!("cannot read {}: {e}", path.display())))?;
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

fn scale(tempo: f64) -> anyhow::Result<TempoScale> {
    TempoScale::new(tempo).ok_or_else(|| {
        bad_input(format!(
            "--tempo {tempo}: give a factor above 0, such as 0.5 or 1.25"
        ))
    })
}

/// The report of a performance, with the same piece rendered without compensation beside it.
fn report(
    song: &Song,
    robot: &Robot,
    options: Options,
    played: &Outcome,
) -> anyhow::Result<Report> {
    let plain = Options {
        compensation: false,
        ..options
    };
    let uncompensated = render(song, robot, plain)?;
    Ok(Report::new(song.notes() as u64, played, &uncompensated))
}

/// Plays on the virtual clock: as fast as the machine goes.
pub fn render(song: &Song, robot: &Robot, options: Options) -> anyhow::Result<Outcome> {
    perform(song, robot, options, None, |_| true)
}

pub fn run_play(args: &PlayArgs) -> anyhow::Result<()> {
    let song = load_song(&args.file)?;
    let robot = load_robot(args.robot.as_deref())?;
    let options = Options {
        compensation: !args.no_compensation,
        scale: scale(args.tempo)?,
    };
    let played = if args.fast {
        render(&song, &robot, options)?
    } else {
        play_live(&song, &robot, options, args)?
    };
    print_report(
        &report(&song, &robot, options, &played)?,
        args.json,
        &args.file,
    )
}

fn play_live(
    song: &Song,
    robot: &Robot,
    options: Options,
    args: &PlayArgs,
) -> anyhow::Result<Outcome> {
    let mut clock = RealClock::new();
    let show = !args.no_view && std::io::stdout().is_terminal();
    let mut view = if show { Some(View::start()?) } else { None };
    let title = args
        .file
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let low = robot.config.range.low().get();
    let total_s = song.duration_us() as f64 / 1e6 / options.scale.get();
    let mut view_error = None;
    let outcome = perform(song, robot, options, Some(&mut clock), |p| {
        let Some(v) = view.as_mut() else { return true };
        let (bar, beat) = song.bar_beat(p.song_us);
        let scene = Scene {
            title: title.clone(),
            low_note: low,
            down: p.engine.keys_down(),
            bar,
            beat,
            bpm: song.tempo_at(p.song_us).bpm() * options.scale.get(),
            elapsed_s: p.song_us as f64 / 1e6 / options.scale.get(),
            total_s,
            notes_sent: p.notes_sent,
            notes: song.notes() as u64,
        };
        if let Err(e) = v.draw(&scene) {
            view_error = Some(e);
            return false;
        }
        !crate::view::quit_requested()
    });
    drop(view);
    if let Some(e) = view_error {
        return Err(e.into());
    }
    outcome
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

pub fn run_analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    let song = load_song(&args.file)?;
    let robot = load_robot(args.robot.as_deref())?;
    let options = Options {
        compensation: true,
        scale: scale(args.tempo)?,
    };
    let played = render(&song, &robot, options)?;
    let report = report(&song, &robot, options, &played)?;
    if args.json {
        return print_report(&report, true, &args.file);
    }
    let mut out = std::io::stdout().lock();
    writeln!(out, "{}", args.file.display())?;
    for finding in findings(&song, &robot, &report) {
        writeln!(out, "- {finding}")?;
    }
    writeln!(out)?;
    write!(out, "{}", report.text())?;
    Ok(())
}

/// What will go wrong, in words.
fn findings(song: &Song, robot: &Robot, r: &Report) -> Vec<String> {
    let mut f = Vec::new();
    let sounded = r.played + r.folded;
    let share = |n: u32| 100.0 * n as f64 / r.notes.max(1) as f64;
    if r.notes == 0 {
        f.push("the file has no notes to play".into());
        return f;
    }
    f.push(format!(
        "{} of {} notes ({:.1}%) will be played; {:.3} s long",
        sounded,
        r.notes,
        share(sounded),
        song.duration_us() as f64 / 1e6
    ));
    let d = &r.dropped;
    let budget = robot.config.guard.max_keys_down;
    let counted: [(u64, String); 8] = [
        (
            r.folded.into(),
            "notes are outside the keys and will be folded by octaves".into(),
        ),
        (
            d.range.into(),
            "notes are outside the keys and will not be played".into(),
        ),
        (
            d.channel.into(),
            "notes are on channels the robot does not listen to".into(),
        ),
        (
            d.power.into(),
            format!(
                "notes would pass the power budget of {budget} keys at once and will be refused"
            ),
        ),
        (
            r.restrikes_delayed.into(),
            "repeated notes come too fast and will strike late to let the key rest".into(),
        ),
        (
            r.cut_by_hold_limit.into(),
            "keys are held past the hold limit and will be cut short".into(),
        ),
        (
            r.too_short_to_sound,
            "presses are too short for the key to sound".into(),
        ),
        (
            r.smeared,
            "presses come before the key is back up and will smear".into(),
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
