//! `orch calibrate`: the calibration score out, or a recording of it in and the calibrated
//! robot.toml (or the measurements) out. The method is `orch-calibrate`'s; this is only the
//! reading, writing and printing.

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use orch_calibrate::{analyze, robot_toml, Anchor, CalibrateError, Calibration, Recording, Score};

use crate::cli::CalibrateArgs;
use crate::error::bad_input;
use crate::robot::{Robot, DEFAULT_TOML};

fn input_error(e: CalibrateError) -> anyhow::Error {
    if e.is_bad_input() {
        bad_input(e.to_string())
    } else {
        anyhow::Error::new(e)
    }
}

/// The robot and its file's text (the default robot's when none is given).
fn robot(path: Option<&Path>) -> anyhow::Result<(Robot, String)> {
    match path {
        Some(p) => {
            let robot = Robot::load(p)?;
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            Ok((robot, text))
        }
        None => Ok((Robot::thesis(), DEFAULT_TOML.to_string())),
    }
}

/// The measurements as JSON: `orch_calibrate::Calibration`'s own (the figures rounded to
/// hundredths).
pub fn json(cal: &Calibration) -> serde_json::Value {
    serde_json::to_value(cal).expect("a calibration is JSON")
}

/// Runs `orch calibrate`.
pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    let (robot, text) = robot(args.robot.as_deref())?;
    let score = Score::for_robot(&robot, args.levels).map_err(input_error)?;
    if let Some(path) = &args.score {
        std::fs::write(path, score.to_smf())
            .with_context(|| format!("writing {}", path.display()))?;
        let ms = score.length_ms();
        eprintln!(
            "orch: calibration score written to {}: {} keys at {} levels ({:?}), {} min {} s; \
             play it with `orch play {} --no-compensation --out ...` and record it",
            path.display(),
            score.high - score.low + 1,
            score.velocities.len(),
            score.velocities,
            ms / 60_000,
            ms % 60_000 / 1000,
            path.display()
        );
        return Ok(());
    }
    let path = args.wav.as_ref().expect("clap requires --score or --wav");
    let anchor: Option<Anchor> = args
        .anchor
        .as_deref()
        .map(str::parse)
        .transpose()
        .map_err(input_error)?;
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let rec = Recording::read(std::io::BufReader::new(file))
        .map_err(input_error)
        .with_context(|| path.display().to_string())?;
    let cal = analyze(&rec, &robot, &score, anchor)
        .map_err(input_error)
        .with_context(|| path.display().to_string())?;
    let mut out = std::io::stdout().lock();
    if args.json {
        writeln!(out, "{}", json(&cal))?;
    } else {
        let toml = robot_toml::calibrated(&text, &cal).map_err(input_error)?;
        out.write_all(toml.as_bytes())?;
    }
    if !cal.anchor.given {
        eprintln!(
            "orch: press delays are relative to note {}'s press_delay in the robot file ({} ms): \
             give --anchor NOTE=MS for true ones",
            cal.anchor.note, cal.anchor.press_delay_ms
        );
    }
    for w in &cal.warnings {
        eprintln!("orch: warning: {w}");
    }
    for k in cal.keys_with_problems() {
        eprintln!("orch: note {}: {}", k.note, k.problems.join("; "));
    }
    Ok(())
}
