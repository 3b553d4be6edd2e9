//! Calibration of strike outputs on synthetic recordings: the drums instrument (PCA9685
//! boards) with hidden flights, softest duties and gains, its drums synthesised
//! (`synthetic::kit`), at 40, 30 and 20 dB SNR with reverberation, anchored on the snare.
//!
//! `cargo bench -p orch-calibrate --bench strikes -- [SEEDS]`

use orch_calibrate::synthetic::kit::{flight, hidden_outputs, line_at, record};
use orch_calibrate::synthetic::Room;
use orch_calibrate::{analyze, Anchor, Score};

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let text =
        orch_robot::instrument_toml(orch_robot::Instrument::Drums, orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let ms = score.length_ms();
    println!(
        "drums: {} outputs x {} levels, {} min {} s to play",
        score.outputs.len(),
        score.velocities.len(),
        ms / 60_000,
        ms % 60_000 / 1000
    );
    println!("snr_db seed | each hit |err| median / max ms | flight max | soft_flight max | hits wrong (heard/silent) | analysis s");
    for snr in [40.0, 30.0, 20.0] {
        for seed in 1..=seeds {
            let hidden = hidden_outputs(&score, &robot, seed);
            let room = Room {
                rate: 44_100,
                capture_offset_ms: 1234.5 + 100.0 * seed as f64,
                snr_db: Some(snr),
                reverb: true,
                thump: None,
                seed,
            };
            let rec = record(&score, &robot, &[], &hidden, &room);
            let anchor = Anchor {
                note: 38,
                press_delay_ms: hidden[1].beater.press_delay_ms,
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
            let (mut errs, mut wrong, mut fl, mut soft) = (Vec::new(), 0, 0.0f64, 0.0f64);
            for (i, (o, h)) in cal.outputs.iter().zip(&hidden).enumerate() {
                for l in &o.levels {
                    match (
                        flight(&score, &robot, &hidden, i, l.velocity),
                        l.press_delay_ms,
                    ) {
                        (Some(t), Some(d)) => errs.push((d - t).abs()),
                        (None, None) => {}
                        _ => wrong += 1,
                    }
                }
                if let Some(f) = o.fit {
                    let s = f64::from(robot.mechanics.for_key(o.key).softest) / 4095.0;
                    fl = fl.max((f.flight_ms - h.beater.press_delay_ms).abs());
                    soft = soft.max((f.soft_flight_ms - line_at(&h.beater, s)).abs());
                }
            }
            errs.sort_by(f64::total_cmp);
            let median = errs.get(errs.len() / 2).copied().unwrap_or(f64::NAN);
            let max = errs.last().copied().unwrap_or(f64::NAN);
            println!(
                "{snr} {seed} | {median:.2} / {max:.2} | {fl:.2} | {soft:.2} | {wrong} | {secs:.2}"
            );
        }
    }
}
