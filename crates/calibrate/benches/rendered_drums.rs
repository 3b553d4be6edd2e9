//! Calibration of a drum kit on rendered sound: the drums instrument (PCA9685 boards), each
//! output's `flight` and `soft_flight` drawn at random and hidden, plays the calibration
//! score on the virtual robot without compensation; `orch-render` makes it sound through the
//! installed SoundFont's GM drum kit (TimGM6mb: its own samples, their own attacks); a room
//! adds a capture offset, reverberation (0.6 s, 0 dB direct-to-reverberant) and noise at 30
//! dB SNR. Anchored on the snare. Each hit's measured flight against the virtual robot's.
//!
//! `cargo bench -p orch-calibrate --bench rendered_drums -- [SEEDS] [-v]` (`-v`: each
//! level's error)

#[path = "../tests/support/rendered.rs"]
mod rendered;

use orch_calibrate::synthetic::Rng;
use orch_calibrate::{analyze, Anchor, Score};
use orch_render::{events, synth, Settings};
use orch_robot::Robot;

/// The drums robot.toml with each output's flights drawn from `rng`: flight 5–25 ms, soft
/// flight 3–15 ms more.
fn hidden_text(rng: &mut Rng) -> String {
    let text =
        orch_robot::instrument_toml(orch_robot::Instrument::Drums, orch_robot::BoardKind::Pwm);
    let mut doc: toml::Table = text.parse().unwrap();
    let outputs = doc["strike"].as_array_mut().unwrap()[0]["output"]
        .as_array_mut()
        .unwrap();
    for o in outputs {
        let t = o.as_table_mut().unwrap();
        let flight = rng.range(5.0, 25.0);
        let soft = flight + rng.range(3.0, 15.0);
        t.insert("flight".into(), format!("{:.0}us", flight * 1000.0).into());
        t.insert(
            "soft_flight".into(),
            format!("{:.0}us", soft * 1000.0).into(),
        );
    }
    toml::to_string(&doc).unwrap()
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let text =
        orch_robot::instrument_toml(orch_robot::Instrument::Drums, orch_robot::BoardKind::Pwm);
    let robot = Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let font = rendered::installed_font();
    let rate = rendered::RATE;
    println!(
        "seed | per output: name (each hit's mean error ms, its spread over the levels ms; \
         fitted flight / soft_flight error ms) | each hit |err| median / max ms | fitted max ms"
    );
    for seed in 1..=seeds {
        let mut rng = Rng::new(seed);
        let hidden = Robot::from_toml(&hidden_text(&mut rng)).unwrap();
        let song = orch_seq::Song::parse(&score.to_smf()).unwrap();
        let played = rendered::play(&song, &rendered::setup(&hidden, false));
        let outputs: Vec<events::Output> = score
            .outputs
            .iter()
            .map(|o| events::Output::drum(o.note))
            .collect();
        let keys = events::from_robot(&played.performance, played.start_us, &outputs, &[]).unwrap();
        let offset_ms = 1234.5;
        let mut x = vec![0.0f64; (offset_ms / 1000.0 * f64::from(rate)) as usize];
        synth::render(&font, &keys, &Settings::default(), |l, r| {
            x.extend(l.iter().zip(r).map(|(a, b)| 0.5 * f64::from(a + b)));
            Ok(())
        })
        .unwrap();
        x.resize(x.len() + rate as usize * 3, 0.0);
        x = rendered::convolve(&x, &rendered::impulse_response(0.6, 0.0, &mut rng));
        let power = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
        let sigma = (power / 1000.0).sqrt();
        let samples: Vec<f32> = x
            .iter()
            .map(|v| (v + sigma * rng.normal()) as f32)
            .collect();
        let rec = orch_calibrate::Recording::from_samples(rate, samples);
        // The truth: the virtual robot's flight at each strike's duty.
        let truth = |key: u8, velocity: u8| {
            let touch = hidden.config.dynamics.keys[usize::from(key)];
            let duty = touch
                .strike_duty(orch_core::Velocity::new(velocity).unwrap())
                .get();
            let m = hidden.mechanics.for_key(key);
            m.sounds_at(duty)
                .then(|| m.press_delay_at(duty).as_micros() as f64 / 1000.0)
        };
        let snare = score.outputs.iter().find(|o| o.note == 38).unwrap();
        let anchor = Anchor {
            note: 38,
            press_delay_ms: truth(snare.key, 127).unwrap(),
        };
        let cal = match analyze(&rec, &robot, &score, Some(anchor)) {
            Ok(c) => c,
            Err(e) => {
                println!("{seed} | refused: {e}");
                continue;
            }
        };
        let mut all = Vec::new();
        let mut line = Vec::new();
        let mut fit_max: f64 = 0.0;
        for o in &cal.outputs {
            let errs: Vec<f64> = o
                .levels
                .iter()
                .filter_map(|l| Some(l.press_delay_ms? - truth(o.key, l.velocity)?))
                .collect();
            let wrong = o
                .levels
                .iter()
                .filter(|l| l.press_delay_ms.is_some() != truth(o.key, l.velocity).is_some())
                .count();
            if std::env::args().any(|a| a == "-v") {
                let each: Vec<String> = o
                    .levels
                    .iter()
                    .map(|l| match (l.press_delay_ms, truth(o.key, l.velocity)) {
                        (Some(d), Some(t)) => format!("v{} {:+.2}", l.velocity, d - t),
                        (d, t) => format!(
                            "v{} heard {} sounds {}",
                            l.velocity,
                            d.is_some(),
                            t.is_some()
                        ),
                    })
                    .collect();
                println!("    {}: {}", o.name, each.join(", "));
            }
            let mean = errs.iter().sum::<f64>() / errs.len().max(1) as f64;
            let spread = errs.iter().copied().fold(f64::MIN, f64::max)
                - errs.iter().copied().fold(f64::MAX, f64::min);
            let m = hidden.mechanics.for_key(o.key);
            let fitted = o.fit.map_or(String::from("not fitted"), |f| {
                let full = m.press_delay.as_micros() as f64 / 1000.0;
                let soft = m.soft_press_delay.as_micros() as f64 / 1000.0;
                let (e1, e2) = (f.flight_ms - full, f.soft_flight_ms - soft);
                fit_max = fit_max.max(e1.abs()).max(e2.abs());
                format!("{e1:+.2}/{e2:+.2}")
            });
            let wrong = if wrong > 0 {
                format!(", {wrong} wrong")
            } else {
                String::new()
            };
            line.push(format!(
                "{} ({mean:+.2}, {spread:.2}{wrong}; {fitted})",
                o.name
            ));
            all.extend(errs.iter().map(|e| e.abs()));
        }
        all.sort_by(f64::total_cmp);
        println!(
            "{seed} | {} | {:.2} / {:.2} | fitted max {fit_max:.2}",
            line.join(", "),
            all.get(all.len() / 2).copied().unwrap_or(f64::NAN),
            all.last().copied().unwrap_or(f64::NAN)
        );
    }
}
