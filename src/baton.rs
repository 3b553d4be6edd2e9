//! `orch baton`: follow a conductor's baton (a red LED at its tip) in a video and print each
//! beat as it is found. The tracker is `orch-baton`'s; this is only the reading and printing.

use std::io::Write;

use anyhow::Context;
use orch_baton::source::{self, SourceError};
use orch_baton::{Baton, Beat, Frame};

use crate::cli::BatonArgs;
use crate::error::bad_input;

fn source_error(e: SourceError) -> anyhow::Error {
    match e {
        SourceError::BadInput(m) => bad_input(m),
        SourceError::Io(e) => anyhow::Error::new(e).context("reading the video"),
    }
}

fn round(v: f64, places: i32) -> f64 {
    let k = 10f64.powi(places);
    (v * k).round() / k
}

/// One beat as a JSON line: `{"t_ms":T,"bpm":B,"x":X,"y":Y}` (`bpm` null at the first beat).
pub fn beat_json(b: &Beat) -> String {
    serde_json::json!({
        "t_ms": round(b.t_ms, 1),
        "bpm": b.bpm.map(|v| round(v, 2)),
        "x": round(b.x, 1),
        "y": round(b.y, 1),
    })
    .to_string()
}

/// Runs `orch baton`.
pub fn run(args: &BatonArgs) -> anyhow::Result<()> {
    if let Some(fps) = args.fps {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(bad_input(format!(
                "--fps {fps}: give frames per second above 0"
            )));
        }
    }
    let mut src = source::open(&args.video, args.fps).map_err(source_error)?;
    let fps = src.fps();
    let mut baton = Baton::default();
    let mut frame = Frame::default();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let (mut frames, mut beats, mut last_t) = (0u64, 0u64, 0.0);
    let mut last_bpm = None;
    while let Some(t) = src.next_frame(&mut frame).map_err(source_error)? {
        frames += 1;
        last_t = t;
        let Some(b) = baton.push(t, &frame) else {
            continue;
        };
        beats += 1;
        last_bpm = b.bpm.or(last_bpm);
        if args.json {
            writeln!(out, "{}", beat_json(&b))
        } else {
            let bpm = b.bpm.map_or("   -  ".to_string(), |v| format!("{v:6.1}"));
            writeln!(
                out,
                "beat {beats:4}  {:9.1} ms  {bpm} BPM  at ({:5.1}, {:5.1})",
                b.t_ms, b.x, b.y
            )
        }
        .and_then(|()| out.flush())
        .context("writing a beat")?;
    }
    if frames == 0 {
        return Err(bad_input(format!(
            "{}: no frames in it",
            args.video.display()
        )));
    }
    if !args.json {
        writeln!(
            out,
            "{frames} frames ({:.1} s at {fps} fps), {beats} beats{}",
            last_t / 1000.0 + 1.0 / fps,
            last_bpm.map_or(String::new(), |v| format!(", tempo at the end {v:.1} BPM"))
        )
        .context("writing the summary")?;
    }
    Ok(())
}
