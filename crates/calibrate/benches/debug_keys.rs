//! Per-key detail of one synthetic calibration (for development).
//!
//! `cargo bench -p orch-calibrate --bench debug_keys -- [SNR] [rev|dry] [SEED]`
use orch_calibrate::synthetic::{duty, hidden_robot, record, Room};
use orch_calibrate::{analyze, Anchor, Score};

fn main() {
    let snr: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(30.0);
    let reverb = std::env::args().nth(2).is_none_or(|s| s != "dry");
    let text = orch_robot::default_toml(orch_robot::BoardKind::Pwm);
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let seed: u64 = std::env::args()
        .nth(3)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let keys = hidden_robot(36, 96, (0.40, 0.75), seed);
    let room = Room {
        rate: 44_100,
        capture_offset_ms: 1234.5,
        snr_db: Some(snr),
        reverb,
        thump: None,
        seed,
    };
    let rec = record(&score, &robot, &keys, &room);
    let anchor = Anchor {
        note: 60,
        press_delay_ms: keys[24].press_delay_ms,
    };
    let cal = analyze(&rec, &robot, &score, Some(anchor)).unwrap();
    println!(
        "offset {:.2} (true {:.2})",
        cal.capture_offset_ms, room.capture_offset_ms
    );
    for (k, h) in cal.keys.iter().zip(&keys) {
        let mut line = format!("{} s={:.3} |", k.note, h.softest);
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
                " fit s={:.3} pd {:+.2}",
                f.softest_percent / 100.0,
                f.press_delay_ms - h.press_delay_ms
            );
        }
        println!("{line} {:?}", k.problems);
    }
}
