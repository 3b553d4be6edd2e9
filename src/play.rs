//! `orch play`: a Standard MIDI File performed on the virtual robot (or the robots `--out`
//! names), live or on the virtual clock (`--fast`), and the report. The work is
//! `orch-stage`'s (loading, setting up, playing, the report, the account); here: the
//! arguments, the files and the printing (the live view is [`crate::live`]'s).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use orch_io::OutSpec;
use orch_perform::{Setup, Tempo};
use orch_seq::Song;
use orch_stage::play::{Leaves, Play, PlayError};
use orch_stage::session::{Ended, Lane};
use orch_stage::{load_robot, load_song, text, Reports};

use crate::cli::PlayArgs;
use crate::error::bad_input;
use crate::live::{failed, init_logging, note_priority, play_live, LiveOptions, Terminal};

/// `--tempo`: the factor, if a session takes it.
pub(crate) fn tempo(factor: f64) -> anyhow::Result<Tempo> {
    orch_stage::setup::tempo(factor).with_context(|| format!("--tempo {factor}"))
}

pub fn run_play(args: &PlayArgs) -> anyhow::Result<()> {
    init_logging(args.verbose);
    if args.link {
        return run_linked(args);
    }
    let play = Play::file(&args.file)
        .robot(args.robot.as_deref())
        .outs(&args.outs)
        .tempo(args.tempo)
        .from_bar(args.from)
        .compensation(!args.no_compensation)
        .fast(args.fast)
        .writes_to(args.writes.as_deref())
        .notes_to(args.notes.as_deref());
    // On the virtual clock (`--fast`) nobody watches: the terminal stays as it is.
    let mut terminal = Terminal::new(LiveOptions {
        command: "orch play",
        view: !args.no_view,
        file: &args.file,
        from_us: None,
        conductor: None,
        steered: None,
    });
    let performed = play.watch(|s| terminal.watch(s)).run();
    // The terminal is given back before anything is said.
    drop(terminal);
    if let Ok(p) = &performed {
        note_priority(p.priority_refused);
    }
    let performed = performed.map_err(said)?;
    // The comparison without compensation is `orch analyze`'s: a play renders once.
    print_reports(&performed.ended, args.json, &args.file, performed.named)
}

/// `orch play --link`: the song steered by an Ableton Link session, which must be joined
/// (after the song, the robot and the tempo are read, before the files and the outputs are
/// opened) and followed while the song plays; step by step here until the session builder
/// takes a Link clock (see `orch_stage::play::Play::steered_by` and `Play::clock`). `--fast`
/// and `--from` do not go with `--link` (clap refuses them): the session sets the pace and
/// the place.
fn run_linked(args: &PlayArgs) -> anyhow::Result<()> {
    let song = load_song(&args.file)?;
    let robot = load_robot(args.robot.as_deref())?;
    let mut setup = orch_stage::setup::setup(&robot, !args.no_compensation, tempo(args.tempo)?);
    if args.tempo != 1.0 {
        return Err(bad_input(
            "--tempo: with --link the session sets the pace; leave out --tempo",
        ));
    }
    // Joined, and the session playing, before anything opens; the tempo is the session's.
    let give_up = orch_stage::signals::stop_flag()?;
    let Some(joined) = crate::link::join(&song, &setup, args.start, &give_up)? else {
        return Ok(());
    };
    setup.tempo = joined.tempo;
    if args.writes.is_some() {
        // Every write is kept for the file, not only the presses the report needs.
        setup.sim.keep = orch_sim::Keep::Everything;
    }
    let writes = create(&args.writes, "--writes")?;
    let notes_file = create(&args.notes, "--notes")?;
    // The song is kept for the account's bars and beats (a live play takes it).
    let song_for_notes = args.notes.is_some().then(|| song.clone());
    let lanes = open_lanes(out_specs(&args.outs)?, &setup)?;
    let live = LiveOptions {
        command: "orch play",
        view: !args.no_view,
        file: &args.file,
        from_us: joined.from_us,
        conductor: None,
        steered: Some((Arc::clone(&joined.control), joined.origin)),
    };
    let played = play_linked(song, lanes, live, &joined)?;
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

/// [`play_live`], kept on the Link session's beat with `--link`.
fn play_linked(
    song: Song,
    lanes: Vec<Lane>,
    live: LiveOptions<'_>,
    joined: &crate::link::Joined,
) -> anyhow::Result<Vec<Ended>> {
    #[cfg(feature = "link")]
    {
        let following = joined.follow();
        let played = play_live(song, lanes, live);
        following.end();
        played
    }
    #[cfg(not(feature = "link"))]
    {
        // Never joined without the feature (`join` refuses), so never here.
        let _ = joined;
        play_live(song, lanes, live)
    }
}

/// A play's error as `orch play` says it: with the option at fault, bad input (exit 2) where
/// the user's input is; the note on real-time priority said first for a live one.
fn said(e: PlayError<anyhow::Error>) -> anyhow::Error {
    let option = |leaves| match leaves {
        Leaves::Notes => "--notes",
        Leaves::Writes => "--writes",
    };
    match e {
        PlayError::Song(e) | PlayError::Fast(e) => anyhow::Error::new(e),
        PlayError::From { bar, error } => {
            anyhow::Error::new(error).context(format!("--from {bar}"))
        }
        PlayError::Robot(e) => anyhow::Error::new(e),
        PlayError::Tempo { factor, error } => {
            anyhow::Error::new(error).context(format!("--tempo {factor}"))
        }
        PlayError::File {
            leaves,
            path,
            source,
            created: true,
        } => bad_input(format!("{} {}: {source}", option(leaves), path.display())),
        PlayError::File {
            leaves,
            path,
            source,
            ..
        } => anyhow::Error::new(source).context(format!("{} {}", option(leaves), path.display())),
        PlayError::Out(e) => crate::error::live(e),
        PlayError::FastOut(out) => bad_input(format!(
            "--fast renders on the virtual clock, as fast as the machine goes: it cannot play \
             --out {out}; leave out --fast"
        )),
        PlayError::Live {
            priority_refused,
            error,
        } => {
            note_priority(priority_refused);
            failed(error)
        }
    }
}

/// Creates the file an option names, if it names one.
pub(crate) fn create(
    path: &Option<PathBuf>,
    option: &str,
) -> anyhow::Result<Option<BufWriter<File>>> {
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
    orch_stage::session::open_lanes(specs, setup).map_err(crate::error::live)
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

/// The `--out` options; the virtual robot alone when there is none.
pub(crate) fn out_specs(outs: &[String]) -> anyhow::Result<Vec<OutSpec>> {
    orch_stage::session::out_specs(outs).map_err(crate::error::live)
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
