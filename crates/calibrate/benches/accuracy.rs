//! Calibration accuracy on synthetic recordings at 40, 30 and 20 dB SNR (with reverberation,
//! a capture offset and the anchor), and how long the score takes to play.
//!
//! `cargo bench -p orch-calibrate --bench accuracy -- [SEEDS]`

use orch_calibrate::synthetic::{clear_of_floor, errors, hidden_robot, record, Room};
use orch_calibrate::{analyze, robot_toml, Anchor, Score};

/// Levels fainter than this (velocity scale; -27 dB against full power) are kept out of the
/// hidden robots: see `clear_of_floor`.
const FLOOR: f64 = 12.0;

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let text = orch_robot::default_toml(orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    println!(
        "calibration score, 61 keys x 4 levels: {:.0} s ({} min {} s) to play",
        f64::from(score.length_ms()) / 1000.0,
        score.length_ms() / 60_000,
        score.length_ms() % 60_000 / 1000
    );
    println!("snr_db seed | delay err median / max / max from E3 ms | press_delay max ms | velocity steps median / max | softest wrong | missed | analysis s");
    for snr in [40.0, 30.0, 20.0] {
        for seed in 0..seeds {
            let mut keys = hidden_robot(36, 96, (0.40, 0.75), seed);
            clear_of_floor(&mut keys, &score, &robot, FLOOR);
            let room = Room {
                rate: 44_100,
                capture_offset_ms: 1234.5 + 100.0 * seed as f64,
                snr_db: Some(snr),
                reverb: true,
                thump: None,
                seed,
            };
            let rec = record(&score, &robot, &keys, &room);
            let anchor = Anchor {
                note: 60,
                press_delay_ms: keys[24].press_delay_ms,
            };
            let t = std::time::Instant::now();
            let cal = match analyze(&rec, &robot, &score, Some(anchor)) {
                Ok(c) => c,
                Err(e) => {
                    println!("{snr} {seed} | refused: {e}");
                    continue;
                }
            };
            let secs = t.elapsed().as_secs_f64();
            let out = robot_toml::calibrated(&text, &cal).unwrap();
            let calibrated = orch_robot::Robot::from_toml(&out).unwrap();
            let e = errors(&cal, &calibrated, &robot, &keys, &score);
            println!(
                "{snr} {seed} | {:.2} / {:.2} / {:.2} | {:.2} | {:.1} / {:.1} | {:?} | {:?} | {secs:.1}",
                e.delay_median_ms,
                e.delay_max_ms,
                e.delay_max_from_e3_ms,
                e.press_delay_max_ms,
                e.velocity_median_steps,
                e.velocity_max_steps,
                e.softest_wrong,
                e.missed
            );
        }
    }
}
