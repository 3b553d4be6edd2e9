//! Calibration accuracy on *rendered* recordings at 40, 30 and 20 dB SNR: the virtual robot
//! with hidden per-key mechanics plays the 61-key, 4-level score without compensation,
//! `orch-render` makes it sound (through the struck-string test font, and through the
//! installed soundfont), a room adds a capture offset, reverberation and noise, and the
//! calibration (with the anchor on middle C) is compared with the hidden figures. Also how
//! fast the score renders, and how long it takes to play.
//!
//! `cargo bench -p orch-calibrate --bench rendered -- [SEEDS]`

#[path = "../tests/support/rendered.rs"]
mod rendered;

use std::time::Instant;

use orch_calibrate::synthetic::errors;
use orch_calibrate::{analyze, robot_toml, Anchor, Score};

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let text = orch_robot::default_toml(orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let ms = score.length_ms();
    println!(
        "calibration score, 61 keys x 4 levels: {:.0} s ({} min {} s) to play",
        f64::from(ms) / 1000.0,
        ms / 60_000,
        ms % 60_000 / 1000
    );
    println!(
        "font snr_db seed | press_delay max ms | each level's delay median / max ms | \
         velocity steps median / max | keys over 3 steps (velocity 1 silent) | softest wrong | missed | \
         median onset error ms, bach-bwv846-prelude on the hidden robot with the written robot.toml | \
         render x real time | analysis s"
    );
    for (name, font) in [
        ("string", rendered::string_font()),
        ("installed", rendered::installed_font()),
    ] {
        for snr in [40.0, 30.0, 20.0] {
            for seed in 0..seeds {
                let hidden = rendered::hidden(&text, (0.40, 0.75), seed);
                let room = rendered::Room {
                    capture_offset_ms: 1234.5 + 100.0 * seed as f64,
                    reverb: Some((0.6, 0.0)),
                    snr_db: Some(snr),
                    thump: None,
                    seed,
                };
                let t = Instant::now();
                let rec = rendered::record(&score, &hidden, &font, &room, None);
                let speed = rec.seconds() / t.elapsed().as_secs_f64();
                let anchor = Anchor {
                    note: 60,
                    press_delay_ms: hidden.keys[24].press_delay_ms,
                };
                let t = Instant::now();
                let cal = match analyze(&rec, &robot, &score, Some(anchor)) {
                    Ok(c) => c,
                    Err(e) => {
                        println!("{name} {snr} {seed} | refused: {e}");
                        continue;
                    }
                };
                let secs = t.elapsed().as_secs_f64();
                let out = robot_toml::calibrated(&text, &cal).unwrap();
                let calibrated = orch_robot::Robot::from_toml(&out).unwrap();
                let e = errors(&cal, &calibrated, &robot, &hidden.keys, &score);
                // The calibrated file's compensation, the hidden robot playing: a corpus file.
                let onset = corpus().map_or(f64::NAN, |song| {
                    rendered::median_abs(&rendered::onset_errors(
                        &song,
                        &calibrated,
                        &hidden.robot.mechanics,
                    ))
                });
                println!(
                    "{name} {snr} {seed} | {:.2} | {:.2} / {:.2} | {:.1} / {:.1} | {} ({}) | {:?} | {:?} | {onset:.2} | {speed:.0} | {secs:.1}",
                    e.press_delay_max_ms,
                    e.delay_median_ms,
                    e.delay_max_ms,
                    e.velocity_median_steps,
                    e.velocity_max_steps,
                    e.velocity_over_3.len(),
                    e.velocity_1_silent.len(),
                    e.softest_wrong,
                    e.missed
                );
            }
        }
    }
}

/// `bach-bwv846-prelude.mid` of the shared corpus, if it is there.
fn corpus() -> Option<orch_seq::Song> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/midi/bach-bwv846-prelude.mid");
    orch_seq::Song::parse(&std::fs::read(path).ok()?).ok()
}
