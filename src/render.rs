//! `orch render`: the virtual robot's performance (or, with `--score`, the file itself) as
//! sound, through a SoundFont, to a WAV file. The work is `orch-render`'s; this parses,
//! builds, runs and prints.

use std::io::Write;
use std::time::Instant;

use anyhow::Context;
use orch_perform::Tempo;
use orch_render::{events, soundfont, synth, wav::WavOut, RenderError, Settings};

use crate::cli::RenderArgs;
use crate::error::bad_input;
use orch_stage::setup::{play_fast, setup};
use orch_stage::{load_robot, load_song};

/// The user's input at fault (a soundfont, a rate) exits 2, anything else 1.
fn lift(e: RenderError) -> anyhow::Error {
    crate::error::lift(e, RenderError::is_bad_input)
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let song = load_song(&args.file)?;
    let font_path = soundfont::find(args.soundfont.as_deref()).map_err(lift)?;
    let robot = load_robot(args.robot.as_deref())?;
    if !(16_000..=192_000).contains(&args.rate) {
        return Err(bad_input(format!(
            "--rate {}: give 16000 to 192000 samples a second",
            args.rate
        )));
    }
    let started = Instant::now();
    let (keys, what) = if args.score {
        (events::from_song(&song), "the score")
    } else {
        let mut setup = setup(&robot, true, Tempo::NORMAL);
        // The sounds' key-ups are needed, not only the presses.
        setup.sim.keep = orch_sim::Keep::Everything;
        let played = play_fast(&song, &setup)?;
        let keys = events::from_performance(
            &played.performance,
            played.start_us,
            robot.config.range.low().get(),
        )
        .map_err(lift)?;
        (keys, "the robot")
    };
    let font = soundfont::load(&font_path).map_err(lift)?;
    let settings = Settings {
        sample_rate: args.rate,
        ..Settings::default()
    };
    let mut out =
        WavOut::create(&args.out, args.rate).map_err(|e| bad_input(format!("-o: {e}")))?;
    let rendered = synth::render(&font, &keys, &settings, |l, r| out.write(l, r))
        .map_err(lift)
        .with_context(|| format!("rendering {}", args.out.display()))?;
    out.finish().map_err(lift)?;
    let took = started.elapsed().as_secs_f64();
    let seconds = rendered.frames as f64 / f64::from(args.rate);
    let peak_db = 20.0 * f64::from(rendered.peak.max(1e-12)).log10();
    let mut o = std::io::stdout().lock();
    writeln!(
        o,
        "{}: {} of {}, {:.3} s at {} Hz (stereo, 32-bit float), {} strikes, peak {:.1} dBFS{}; \
         soundfont {}; rendered in {:.3} s ({:.0}x real time)",
        args.out.display(),
        what,
        args.file.display(),
        seconds,
        args.rate,
        rendered.strikes,
        peak_db,
        if rendered.over > 0 {
            format!(" ({} samples past full scale)", rendered.over)
        } else {
            String::new()
        },
        font_path.display(),
        took,
        seconds / took.max(1e-9),
    )?;
    Ok(())
}
