//! The tracker on generated conductor videos, scored against their known beats.
//!
//! The light set runs in debug; the whole suite (every video at 30 and 60 fps) is heavy and
//! runs in release: `cargo test -p orch-baton --release -- --ignored` (scripts/test.sh does).

use orch_baton::synth::{self, Script, Video};
use orch_baton::{Baton, Blob, Params};

fn check_all(scripts: &[Script]) {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let scores = synth::run(scripts, Params::default(), threads);
    assert_eq!(scores.len(), scripts.len());
    let mut failures = Vec::new();
    for s in &scores {
        println!("{}", s.row());
        if let Err(e) = s.check() {
            failures.push(e);
        }
    }
    assert!(
        failures.is_empty(),
        "below the bar:\n{}",
        failures.join("\n")
    );
}

#[test]
fn light_set_meets_the_bars() {
    // Short versions of the hard cases, at 30 fps (the harder rate).
    check_all(&[
        Script::steady("fermata, second red 110", 110.0, 30.0)
            .beats(9)
            .fermata(4, 1200.0)
            .clutter()
            .second_red()
            .seed(3),
        Script::steady("blur, noise, drops 160", 160.0, 30.0)
            .beats(10)
            .blur()
            .noise(10.0)
            .drop(0.08, 0.04)
            .seed(9),
    ]);
}

fn blob(x: f64, y: f64, area: u32, half: f64, peak: u8) -> Blob {
    Blob {
        x,
        y,
        area,
        weight: f64::from(area) * f64::from(peak),
        peak,
        bbox: [
            (x - half).max(0.0) as u32,
            (y - half).max(0.0) as u32,
            (x + half) as u32,
            (y + half) as u32,
        ],
    }
}

/// The tracker, the beat detector and the tempo estimator, on the exact path of every video
/// of the suite at both rates: each delivered frame gives the blobs a perfect detector would
/// (the LED where it shows, in the picture and not hidden; with `second_red`, the sleeve and
/// the standby light too). No drawing, so it is quick in debug; it checks the same bars.
#[test]
fn tracker_and_beats_on_every_path_meet_the_bars() {
    let mut failures = Vec::new();
    for fps in [30.0, 60.0] {
        for script in synth::suite(fps) {
            let (occlude, second_red) = (script.occlude, script.second_red);
            let video = Video::new(script.noise(0.0));
            let mut baton = Baton::default();
            let mut rng = synth::Rng::new(11);
            let mut found = Vec::new();
            let mut frames = 0;
            for i in (0..video.frame_count()).filter(|&i| !video.dropped(i)) {
                frames += 1;
                let t = i as f64 * 1000.0 / fps;
                let (x, y) = video.led_at(t);
                let mut blobs = Vec::new();
                if rng.unit() >= occlude && (0.0..480.0).contains(&y) {
                    blobs.push(blob(x, y, 60, 4.0, 200));
                }
                if second_red {
                    blobs.push(blob(x + 75.0, y + 125.0, 2200, 30.0, 170));
                    blobs.push(blob(90.0, 440.0, 20, 2.0, 130));
                }
                found.extend(baton.push_blobs(t, &blobs));
            }
            let score = synth::score(&video, &found, frames);
            println!("{}", score.row());
            if let Err(e) = score.check() {
                failures.push(e);
            }
        }
    }
    assert!(
        failures.is_empty(),
        "below the bar:\n{}",
        failures.join("\n")
    );
}

#[test]
#[ignore = "heavy: every generated video at 30 and 60 fps; run in release (scripts/test.sh does)"]
fn full_suite_meets_the_bars() {
    let scripts: Vec<Script> = [30.0, 60.0].iter().flat_map(|&f| synth::suite(f)).collect();
    assert!(scripts.len() >= 30);
    check_all(&scripts);
}

#[test]
fn truth_is_what_the_script_says() {
    let v = Video::new(Script::ramp("acc", 80.0, 140.0, 60.0).beats(32));
    assert_eq!(v.truth.len(), 32);
    assert_eq!(v.truth[0].bpm, 80.0);
    assert!((v.truth[31].bpm - 140.0).abs() < 1e-9);
    // The intervals shrink, and each is close to 60 000 / tempo in the middle of it.
    for w in v.truth.windows(2) {
        let interval = w[1].t_ms - w[0].t_ms;
        let mid = 60_000.0 / ((w[0].bpm + w[1].bpm) / 2.0);
        assert!((interval - mid).abs() < 1.0, "{interval} vs {mid}");
    }
    // The ictus is the lowest point of the path around it, and the path is a V there: it
    // falls faster than it rises, unlike a sine.
    for tb in &v.truth[1..31] {
        let (_, y) = v.led_at(tb.t_ms);
        assert!((y - tb.y).abs() < 1e-6);
        for d in [-40.0, -10.0, -1.0, 1.0, 10.0, 40.0] {
            assert!(v.led_at(tb.t_ms + d).1 < y, "not lowest at {}", tb.t_ms + d);
        }
        let before = y - v.led_at(tb.t_ms - 5.0).1;
        let after = y - v.led_at(tb.t_ms + 5.0).1;
        assert!(
            before > 0.5 && after > 0.5,
            "no sharp turn: {before} {after}"
        );
    }
    let f = Video::new(Script::steady("f", 90.0, 30.0).fermata(3, 2500.0));
    let gap = f.truth[4].t_ms - f.truth[3].t_ms;
    assert!((gap - (60_000.0 / 90.0 + 2500.0)).abs() < 1e-6);
}

#[test]
fn a_hidden_led_makes_no_beats_and_dropped_frames_are_not_delivered() {
    let mut script = Script::steady("hidden", 160.0, 30.0)
        .beats(4)
        .drop(0.0, 1.0);
    let v = Video::new(script.clone());
    let score = synth::evaluate(&v, Params::default());
    assert_eq!(score.found, 0);
    assert_eq!(score.missed, 4);
    assert!(score.check().is_err());
    script = script.drop(0.5, 0.0);
    let v = Video::new(script);
    let delivered = (0..v.frame_count()).filter(|&i| !v.dropped(i)).count();
    assert!(delivered < v.frame_count() * 7 / 10 && delivered > v.frame_count() * 3 / 10);
}

#[test]
fn an_overexposed_led_is_white_in_the_middle_and_still_found() {
    let v = Video::new(
        Script::steady("bloom", 120.0, 30.0)
            .beats(4)
            .bloom()
            .noise(0.0),
    );
    let (t, frame) = v.frame_at(3);
    let (x, y) = v.led_at(t);
    let [r, g, b] = frame.pixel(x.round() as usize, y.round() as usize);
    assert!(r > 240 && g > 200 && b > 200, "core {r} {g} {b}");
    let mut blobs = Vec::new();
    orch_baton::Detector::default().detect(&frame, &mut blobs);
    assert_eq!(blobs.len(), 1);
    // A ring round the white core, centred on the LED.
    assert!(
        (blobs[0].x - x).abs() < 0.3 && (blobs[0].y - y).abs() < 0.3,
        "{blobs:?}"
    );
}
