//! Where the velocity curves' error comes from, on one rendered calibration: each sounding
//! level's measured dB against full power, less the level the render gave it (the
//! measurement's error), and that level less the exact loudness's (the render's own, 0 since
//! strikes sound at their exact loudness); each key's fitted softest against the hidden one,
//! in the key's velocity steps (the written curve is within 3 steps when this is within
//! ±1.5). Keys with problems other than a level below the softest are named.
//!
//! `cargo bench -p orch-calibrate --bench level_errors -- [SNR|x] [rev|dry] [ROBOT_SEED] [ROOM_SEED]`
//! (x: no noise; the rendered test's robot is seed 5, its rooms 3, 1 and 6)
#[path = "../tests/support/rendered.rs"]
mod rendered;

use orch_calibrate::fit::{db_of_loudness, loudness};
use orch_calibrate::synthetic::duty;
use orch_calibrate::{analyze, Anchor, Score};

fn main() {
    let arg = |i: usize| std::env::args().nth(i);
    let snr: Option<f64> = arg(1).and_then(|s| s.parse().ok());
    let reverb = arg(2).is_none_or(|s| s != "dry");
    let seed: u64 = arg(3).and_then(|s| s.parse().ok()).unwrap_or(5);
    let room_seed: u64 = arg(4).and_then(|s| s.parse().ok()).unwrap_or(3);
    let text = orch_robot::default_toml(orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let hidden = rendered::hidden(&text, (0.40, 0.75), seed);
    let room = rendered::Room {
        capture_offset_ms: 1712.3,
        reverb: reverb.then_some((0.6, 0.0)),
        snr_db: snr,
        thump: None,
        seed: room_seed,
    };
    let rec = rendered::record(&score, &hidden, &rendered::string_font(), &room, None);
    let anchor = Anchor {
        note: 60,
        press_delay_ms: hidden.keys[24].press_delay_ms,
    };
    let cal = analyze(&rec, &robot, &score, Some(anchor)).unwrap();
    let (mut measured, mut rendered_err, mut steps) = (Vec::new(), Vec::new(), Vec::new());
    for (i, (k, h)) in cal.keys.iter().zip(&hidden.keys).enumerate() {
        if k.problems
            .iter()
            .any(|p| !p.contains("below the key's softest"))
        {
            println!("note {}: {:?}", k.note, k.problems);
        }
        let Some(full) = k.levels.last().and_then(|l| l.level_db) else {
            continue;
        };
        let m = hidden.robot.mechanics.for_key(i as u8);
        let mut line = format!("{} softest {:.4}", k.note, h.softest);
        for l in &k.levels[..k.levels.len() - 1] {
            let Some(level) = l.level_db else { continue };
            let d = duty(&robot, k.note, l.velocity);
            let exact = db_of_loudness(loudness(d, h.softest));
            let played = m.loudness_at((d * 4095.0).round() as u16).unwrap().get();
            let u = orch_render::synth::synth_velocity(played);
            let sounded = 40.0 * (u / 127.0).log10();
            line += &format!(
                " | v{} measured {:+.2} dB, render {:+.2} dB",
                l.velocity,
                level - full - sounded,
                sounded - exact
            );
            measured.push(level - full - sounded);
            rendered_err.push(sounded - exact);
        }
        if let Some(f) = k.fit {
            let e = (f.softest_percent / 100.0 - h.softest) / ((1.0 - h.softest) / 126.0);
            steps.push(e);
            line += &format!(" | softest {e:+.2} steps");
        }
        println!("{line}");
    }
    let rms = |x: &[f64]| (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt();
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len().max(1) as f64;
    println!(
        "levels: measured {:+.3} ± {:.3} dB (mean, rms), render {:.3} dB rms; softest: {:+.2} \
         steps mean, {:.2} rms, {:.2} at worst",
        mean(&measured),
        rms(&measured),
        rms(&rendered_err),
        mean(&steps),
        rms(&steps),
        steps.iter().fold(0f64, |a, b| a.max(b.abs()))
    );
}
