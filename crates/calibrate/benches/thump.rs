//! A solenoid's thump 2–5 ms before each string (`synthetic::Solenoid::ROBOT`), on rendered
//! recordings at 30 dB SNR in a reverberant room: how many strikes come out more than 1.5 ms
//! off, the largest and median error, which octaves, early or late; with the thump and
//! without, the rendered test's robot (seed 5) in its three rooms (3, 1, 6).
//!
//! `cargo run --release -p orch-calibrate --example thump [LEVEL_DB] [-v]` (LEVEL_DB: the
//! thump's level at full power against the string's, `Solenoid::ROBOT`'s unless given; `-v`
//! names each strike over 1.5 ms)

#[path = "../tests/support/rendered.rs"]
mod rendered;

use orch_calibrate::synthetic::{errors, Solenoid};
use orch_calibrate::{analyze, robot_toml, Anchor, Score};

fn main() {
    let level_db: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(Solenoid::ROBOT.level_db);
    let verbose = std::env::args().any(|a| a == "-v");
    let solenoid = Solenoid {
        level_db,
        ..Solenoid::ROBOT
    };
    let text = orch_robot::default_toml(orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    println!(
        "thump robot room | strikes | over 1.5 ms (early, in C2-B3) | max ms | median ms | \
         press_delay max ms | problems"
    );
    for thump in [None, Some(solenoid)] {
        for (seed, room_seed) in [(5, 3), (5, 1), (5, 6)] {
            let hidden = rendered::hidden(&text, (0.40, 0.75), seed);
            let room = rendered::Room {
                capture_offset_ms: 1712.3,
                reverb: Some((0.6, 0.0)),
                snr_db: Some(30.0),
                thump,
                seed: room_seed,
            };
            let rec = rendered::record(&score, &hidden, &rendered::string_font(), &room, None);
            let anchor = Anchor {
                note: 60,
                press_delay_ms: hidden.keys[24].press_delay_ms,
            };
            let name = if thump.is_some() { "thump" } else { "none" };
            let cal = match analyze(&rec, &robot, &score, Some(anchor)) {
                Ok(c) => c,
                Err(e) => {
                    println!("{name} {seed} {room_seed} | refused: {e}");
                    continue;
                }
            };
            let out = robot_toml::calibrated(&text, &cal).unwrap();
            let calibrated = orch_robot::Robot::from_toml(&out).unwrap();
            let e = errors(&cal, &calibrated, &robot, &hidden.keys, &score);
            let over: Vec<_> = e.strikes.iter().filter(|s| s.2.abs() > 1.5).collect();
            let problems = cal
                .keys
                .iter()
                .flat_map(|k| &k.problems)
                .filter(|p| !p.contains("below the key's softest"))
                .count();
            println!(
                "{name} {seed} {room_seed} | {} | {} ({}, {}) | {:.2} | {:.2} | {:.2} | {problems}",
                e.strikes.len(),
                over.len(),
                over.iter().filter(|s| s.2 < 0.0).count(),
                over.iter().filter(|s| s.0 < 60).count(),
                e.delay_max_ms,
                e.delay_median_ms,
                e.press_delay_max_ms,
            );
            if verbose {
                for (note, velocity, err) in over {
                    println!("    note {note} velocity {velocity}: {err:+.2} ms");
                }
            }
        }
    }
}
