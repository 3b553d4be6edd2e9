//! Per-key detail of one rendered calibration (for development): each level's delay error
//! against the hidden robot, its level, the fit, the problems, and the keys whose velocity
//! curve is more than 3 steps off.
//!
//! `cargo bench -p orch-calibrate --bench rendered_keys -- [SNR|x] [rev|dry] [SEED]
//! [string|tim]` (x: no noise; tim: the installed soundfont instead of the test font)
#[path = "../tests/support/rendered.rs"]
mod rendered;

use orch_calibrate::synthetic::duty;
use orch_calibrate::{analyze, Anchor, Score};

fn main() {
    let snr: Option<f64> = std::env::args().nth(1).and_then(|s| s.parse().ok());
    let reverb = std::env::args().nth(2).is_none_or(|s| s != "dry");
    let seed: u64 = std::env::args()
        .nth(3)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let text = orch_robot::default_toml(orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let hidden = rendered::hidden(&text, (0.40, 0.75), seed);
    let room = rendered::Room {
        capture_offset_ms: 1234.5,
        reverb: reverb.then_some((0.6, 0.0)),
        snr_db: snr,
        thump: None,
        seed,
    };
    let font = if std::env::args().nth(4).is_some_and(|s| s == "tim") {
        rendered::installed_font()
    } else {
        rendered::string_font()
    };
    let t = std::time::Instant::now();
    let rec = rendered::record(&score, &hidden, &font, &room, None);
    eprintln!("recorded in {:.1} s", t.elapsed().as_secs_f64());
    let keys = &hidden.keys;
    let anchor = Anchor {
        note: 60,
        press_delay_ms: keys[24].press_delay_ms,
    };
    let cal = analyze(&rec, &robot, &score, Some(anchor)).unwrap();
    println!(
        "offset {:.2} (true {:.2})",
        cal.capture_offset_ms,
        room.offset_ms()
    );
    let out = orch_calibrate::robot_toml::calibrated(&text, &cal).unwrap();
    let calibrated = orch_robot::Robot::from_toml(&out).unwrap();
    for (k, h) in cal.keys.iter().zip(keys) {
        let worst = (1..=127u8)
            .map(|v| {
                let l = h.loudness_at(duty(&calibrated, k.note, v));
                if l == 0.0 {
                    f64::INFINITY
                } else {
                    (l - f64::from(v)).abs()
                }
            })
            .fold(0.0, f64::max);
        if worst > 3.0 {
            println!(
                "VELOCITY {} worst {worst:.1} calibrated softest {:.4}",
                k.note,
                duty(&calibrated, k.note, 1)
            );
        }
        let mut line = format!("{} s={:.4} |", k.note, h.softest);
        for l in &k.levels {
            let d = duty(&robot, k.note, l.velocity);
            let loud = h.loudness_at(d);
            let err = l.press_delay_ms.map(|x| x - h.delay_at(d));
            line += &format!(
                " v{} loud {:.1} err {} db {} |",
                l.velocity,
                loud,
                err.map_or("-".into(), |e| format!("{e:+.2}")),
                l.level_db.map_or("-".into(), |e| format!("{e:.1}"))
            );
        }
        if let Some(f) = k.fit {
            line += &format!(
                " fit s={:.4} pd {:+.2}",
                f.softest_percent / 100.0,
                f.press_delay_ms - h.press_delay_ms
            );
        }
        println!("{line} {:?}", k.problems);
    }
}
