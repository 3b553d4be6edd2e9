//! `orch calibrate`: the calibration score out, or a recording of it in (a WAV file, or
//! recorded live while the robot plays it) and the calibrated robot.toml (or the
//! measurements) out. The method is `orch-calibrate`'s; this is only the reading, writing and
//! printing.

use std::io::Write;

use anyhow::Context;
use orch_calibrate::{analyze, robot_toml, Anchor, CalibrateError, Calibration, Recording, Score};

use crate::cli::CalibrateArgs;
use crate::error::bad_input;
use crate::robot::Robot;

/// The user's input at fault (a score, a recording, an anchor) exits 2, anything else 1.
fn input_error(e: CalibrateError) -> anyhow::Error {
    crate::error::lift(e, CalibrateError::is_bad_input)
}

/// The measurements as JSON: `orch_calibrate::Calibration`'s own (the figures rounded to
/// hundredths).
pub fn json(cal: &Calibration) -> serde_json::Value {
    serde_json::to_value(cal).expect("a calibration is JSON")
}

/// Runs `orch calibrate`.
pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    let (robot, text) = orch_stage::load::load_robot_text(args.robot.as_deref())?;
    let score = Score::for_robot(&robot, args.levels).map_err(input_error)?;
    if let Some(path) = &args.score {
        std::fs::write(path, score.to_smf())
            .with_context(|| format!("writing {}", path.display()))?;
        let ms = score.length_ms();
        let keys = score.keys().count();
        let outputs = match score.outputs.len() {
            0 => String::new(),
            n if keys == 0 => format!("{n} strike outputs"),
            n => format!(" and {n} strike outputs"),
        };
        let keys = if keys == 0 && !score.outputs.is_empty() {
            String::new()
        } else {
            format!("{keys} keys")
        };
        eprintln!(
            "orch: calibration score written to {}: {keys}{outputs} at {} levels ({:?}), \
             {} min {} s; play it with `orch play {} --no-compensation --out ...` and record it",
            path.display(),
            score.velocities.len(),
            score.velocities,
            ms / 60_000,
            ms % 60_000 / 1000,
            path.display()
        );
        return Ok(());
    }
    let anchor: Option<Anchor> = args
        .anchor
        .as_deref()
        .map(str::parse)
        .transpose()
        .map_err(input_error)?;
    let (rec, what) = match (&args.wav, &args.mic) {
        (Some(path), _) => {
            let file =
                std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
            let rec = Recording::read(std::io::BufReader::new(file))
                .map_err(input_error)
                .with_context(|| path.display().to_string())?;
            (rec, path.display().to_string())
        }
        (None, Some(device)) => (record(args, device, &robot, &score)?, device.clone()),
        (None, None) => unreachable!("clap requires --score, --wav or --mic"),
    };
    let cal = analyze(&rec, &robot, &score, anchor)
        .map_err(input_error)
        .with_context(|| what.clone())?;
    if args.mic.is_some() {
        eprintln!(
            "orch: capture offset {:.1} ms (the output's and the microphone's latency beyond \
             the press delays)",
            cal.capture_offset_ms
        );
    }
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
    for line in cal.problem_lines() {
        eprintln!("orch: {line}");
    }
    Ok(())
}

/// `--mic`: the score played on `--out` and recorded at once (orch-calibrate's `live`);
/// SIGINT, SIGTERM and SIGHUP stop the robot (every key released) and the recording.
#[cfg(feature = "mic")]
fn record(
    args: &CalibrateArgs,
    device: &str,
    robot: &Robot,
    score: &Score,
) -> anyhow::Result<Recording> {
    use orch_calibrate::live::{output, take, Keep, TakeError};
    let lift = |e| crate::error::lift(e, TakeError::is_bad_input);
    let out = output(args.out.as_deref().expect("clap requires --out with --mic")).map_err(lift)?;
    let keep = args
        .keep
        .as_deref()
        .map(Keep::create)
        .transpose()
        .map_err(lift)?;
    let mic = orch_calibrate::mic::Mic::open(device).map_err(|e| bad_input(e.to_string()))?;
    let stop = orch_stage::signals::stop_flag()?;
    let ms = score.length_ms();
    eprintln!(
        "orch: playing the calibration score on --out {} and recording it from --mic \
         {device} ({}): {} min {} s",
        out.text,
        mic.format(),
        ms / 60_000,
        ms % 60_000 / 1000
    );
    let take = take(robot, score, out, mic, &stop).map_err(lift)?;
    for w in take.warnings() {
        eprintln!("orch: warning: {w}");
    }
    if let Some(keep) = keep {
        keep.write(&take.recording).map_err(lift)?;
    }
    Ok(take.recording)
}

/// `--mic` without the `mic` feature: said so, with how to build it.
#[cfg(not(feature = "mic"))]
fn record(_: &CalibrateArgs, device: &str, _: &Robot, _: &Score) -> anyhow::Result<Recording> {
    Err(bad_input(format!(
        "--mic {device}: this orch was built without the `mic` feature (live capture \
         through ALSA); build it with `cargo build --release --features mic` (needs \
         libasound2-dev), or record the score yourself and give the recording with --wav"
    )))
}
