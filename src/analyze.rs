//! `orch analyze`: whether the robot can play a Standard MIDI File, and what will go wrong,
//! without playing it live. The analysis is `orch-stage`'s ([`orch_stage::analyze`]); here:
//! the arguments, the files (`--notes`, `--svg`) and the printing.

use std::io::Write;

use anyhow::Context;
use orch_stage::{analyze, load_robot, load_song, text};

use crate::cli::AnalyzeArgs;
use crate::play::{create, tempo};

pub fn run(args: &AnalyzeArgs) -> anyhow::Result<()> {
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
        orch_stage::account::write_account(
            &mut file,
            &song,
            &played,
            orch_io::Channels::ALL,
            setup.tempo,
            None,
        )
        .with_context(|| format!("--notes {}", path.display()))?;
    }
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", analysis.json()?)?;
    } else {
        write!(out, "{}", text::analysis(&analysis, &args.file))?;
    }
    Ok(())
}
