//! `orch render`: the virtual robot's performance (or, with `--score`, the file itself) as
//! sound, through a SoundFont, to a WAV file. The work is `orch-render`'s; this parses,
//! builds, runs and prints.

use std::io::Write;
use std::time::Instant;

use anyhow::Context;
use orch_perform::Played;
use orch_perform::Tempo;
use orch_render::{
    events, soundfont, synth, wav::WavOut, Instrument, Output, RenderError, Settings,
};
use orch_robot::{GroupKind, Robot};

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
        let keys = events::from_robot(
            &played.performance,
            played.start_us,
            &outputs(&robot),
            &strike_notes(&played),
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

/// What each of `robot`'s outputs sounds as: a keyboard key the piano at its note, a kit's
/// output the General MIDI drum kit (at its first note, where the account does not say which
/// of its notes a strike was), a pitched group's bar its program at the bar's note (the
/// glockenspiel where the group names no program); an output in no group, the piano at the
/// note of its place above the keyboard's lowest; a lift sounds nothing, and a damper ends its
/// output's ring.
fn outputs(robot: &Robot) -> Vec<Output> {
    let keys = robot
        .groups
        .iter()
        .map(|g| usize::from(g.first) + g.outputs.len())
        .max()
        .unwrap_or(0);
    (0..keys)
        .map(|k| {
            let key = k as u8;
            let Some(g) = robot.group_of(key) else {
                return Output::key(robot.config.range.low().get().saturating_add(key) & 0x7F);
            };
            let i = usize::from(key - g.first);
            let Some(&note) = g.notes.get(i).and_then(|n| n.first()) else {
                // No note strikes it: a damper (of the output whose damper it is) or a lift.
                let strikes = &robot.config.strikes;
                let bar = (0..keys as u8).find(|&b| strikes.damper(b) == Some(key));
                return bar.map_or_else(Output::silent, Output::damper);
            };
            match g.kind {
                GroupKind::Keyboard => Output::key(note),
                GroupKind::Kit => Output::drum(note),
                GroupKind::Pitched => Output::bar(
                    g.program
                        .and_then(Instrument::gm_program)
                        .unwrap_or(GLOCKENSPIEL),
                    note,
                ),
                // The valve: each of its notes at its own pitch, held until the valve closes.
                GroupKind::Fingered => Output::voice(
                    g.program
                        .and_then(Instrument::gm_program)
                        .unwrap_or(RECORDER),
                    note,
                ),
            }
        })
        .collect()
}

/// General MIDI's glockenspiel (program 10 as people count).
const GLOCKENSPIEL: Instrument = Instrument::Program(9);
/// General MIDI's recorder (program 75 as people count).
const RECORDER: Instrument = Instrument::Program(74);

/// Which note each strike of the performance was, as written: every note that sounded with a
/// strike of its own, its landing key and its sound time (the account's `sounded_ms`, in µs on
/// the performance's clock).
fn strike_notes(played: &Played) -> Vec<events::StrikeNote> {
    played
        .records
        .iter()
        .filter_map(|r| {
            let landing = r.landing?;
            let key = landing.key;
            let onset_us = match r.outcome {
                orch_perform::Outcome::OnTime { error_us } => i64::from(error_us),
                orch_perform::Outcome::Late { by_us } => i64::from(by_us),
                orch_perform::Outcome::Early { by_us } => -i64::from(by_us),
                _ => return None,
            };
            let sounded_us = u64::try_from(r.score_at_us + onset_us).ok()?;
            Some(events::StrikeNote {
                key,
                sounded_us,
                // As it sounds: a note folded into a wind robot's range sounds where it landed.
                note: (i16::from(r.note) + 12 * i16::from(landing.octaves)).clamp(0, 127) as u8,
            })
        })
        .collect()
}
