//! Each stage alone, on hand-made input.

use orch_baton::{BeatDetector, BeatParams, Blob, DetectParams, Detector, Frame, Tracker};

/// A frame with a Gaussian red spot at (x, y) on grey.
fn spot(x: f64, y: f64) -> Frame {
    let mut f = Frame::new(160, 120);
    for py in 0..120 {
        for px in 0..160 {
            let d2 = (px as f64 - x).powi(2) + (py as f64 - y).powi(2);
            let a = (3.0 * (-d2 / 8.0).exp()).min(1.0);
            let i = 3 * (py * 160 + px);
            f.rgb[i] = (60.0 * (1.0 - a) + 255.0 * a) as u8;
            f.rgb[i + 1] = (60.0 * (1.0 - a) + 40.0 * a) as u8;
            f.rgb[i + 2] = (60.0 * (1.0 - a) + 30.0 * a) as u8;
        }
    }
    f
}

#[test]
fn centroid_is_sub_pixel() {
    let mut d = Detector::new(DetectParams::default());
    let mut blobs = Vec::new();
    // A sweep in tenths of a pixel: the thresholded shape moves in whole pixels, the
    // redness-weighted centroid moves smoothly.
    for k in 0..=20 {
        let (x, y) = (80.0 + 0.1 * k as f64, 50.0 + 0.05 * k as f64);
        d.detect(&spot(x, y), &mut blobs);
        assert_eq!(blobs.len(), 1);
        let b = blobs[0];
        assert!(
            (b.x - x).abs() < 0.03 && (b.y - y).abs() < 0.03,
            "({x}, {y}) found at ({}, {})",
            b.x,
            b.y
        );
        assert!(b.area > 10 && b.area < 200);
    }
}

#[test]
fn grey_white_and_brown_are_not_red() {
    let mut f = Frame::new(50, 50);
    for (i, px) in f.rgb.chunks_exact_mut(3).enumerate() {
        let c: [u8; 3] = match i % 4 {
            0 => [255, 255, 255],
            1 => [128, 128, 128],
            2 => [150, 100, 60],
            _ => [230, 180, 160],
        };
        px.copy_from_slice(&c);
    }
    let mut blobs = Vec::new();
    Detector::new(DetectParams::default()).detect(&f, &mut blobs);
    assert!(blobs.is_empty());
}

fn blob(x: f64, y: f64, area: u32, side: u32, peak: u8) -> Blob {
    Blob {
        x,
        y,
        area,
        weight: f64::from(area) * f64::from(peak),
        peak,
        bbox: [
            x as u32 - side / 2,
            y as u32 - side / 2,
            x as u32 + side / 2,
            y as u32 + side / 2,
        ],
    }
}

#[test]
fn the_track_is_preferred_over_a_brighter_blob_and_big_blobs_are_not_leds() {
    let mut t = Tracker::default();
    let led = |k: u32| blob(100.0 + 5.0 * k as f64, 200.0, 60, 9, 150);
    // A sleeve: big and thick, brighter than everything.
    let sleeve = blob(300.0, 300.0, 2500, 56, 220);
    assert!(!t.led_like(&sleeve));
    assert!(t.led_like(&led(0)));
    for k in 0..10 {
        // From frame 3 on, a brighter LED-sized blob far from the track.
        let mut blobs = vec![led(k), sleeve];
        if k >= 3 {
            blobs.push(blob(400.0, 100.0, 70, 9, 250));
        }
        let seen = t.update(k as f64 * 33.3, &blobs);
        let (x, y) = seen.at.expect("the LED");
        assert!(
            (x - led(k).x).abs() < 1e-9 && (y - 200.0).abs() < 1e-9,
            "frame {k}"
        );
        assert_eq!(seen.new_track, k == 0);
    }
}

#[test]
fn a_start_on_a_still_light_switches_to_the_moving_led() {
    let mut t = Tracker::default();
    let mut last = None;
    for k in 0..40u32 {
        let still = blob(50.0, 50.0, 40, 7, 250);
        let moving = blob(
            300.0 + 80.0 * (k as f64 / 3.0).sin(),
            240.0 + 5.0 * k as f64,
            40,
            7,
            200,
        );
        last = t.update(k as f64 * 33.3, &[still, moving]).at;
        if k == 0 {
            assert_eq!(last, Some((50.0, 50.0)), "the brighter one first");
        }
    }
    let (x, _) = last.unwrap();
    assert!(x > 100.0, "still on the standby light");
}

/// A conducting V: y = 300 at the ictus, up at `up` px/ms after, down at `down` before.
fn v_path(ictus: &[f64], t: f64) -> f64 {
    let k = ictus.partition_point(|&i| i <= t);
    let after = if k == 0 {
        f64::INFINITY
    } else {
        t - ictus[k - 1]
    };
    let before = ictus.get(k).map_or(f64::INFINITY, |&i| i - t);
    let y_after = 300.0 - 0.9 * after;
    let y_before = 300.0 - 1.3 * before;
    y_after.max(y_before).max(150.0)
}

#[test]
fn the_ictus_is_found_below_the_frame() {
    // Beats off the frame grid; 30 fps.
    let ictus: Vec<f64> = (0..12).map(|k| 400.0 + 517.3 * k as f64).collect();
    let mut d = BeatDetector::new(BeatParams::default());
    let mut found = Vec::new();
    for i in 0..240 {
        let t = i as f64 * 1000.0 / 30.0;
        found.extend(d.push(t, 10.0, v_path(&ictus, t)));
    }
    assert_eq!(found.len(), ictus.len());
    for (b, &i) in found.iter().zip(&ictus) {
        // An exact V: the fit gives it to well under a ms (a frame is 33 ms).
        assert!((b.t_ms - i).abs() < 0.5, "{} vs {i}", b.t_ms);
        assert!((b.y - 300.0).abs() < 0.5);
    }
    let bpm = found.last().unwrap().bpm.unwrap();
    assert!((bpm - 60_000.0 / 517.3).abs() < 0.05, "{bpm}");
    assert_eq!(found[0].bpm, None);
}

#[test]
fn outliers_do_not_move_the_tempo() {
    let mut d = BeatDetector::new(BeatParams::default());
    let push_v = |d: &mut BeatDetector, at: f64| {
        // Four samples around a V at `at`, plus a top before.
        let mut out = None;
        for (dt, y) in [
            (-200.0, 100.0),
            (-20.0, 280.0),
            (0.0, 300.0),
            (20.0, 280.0),
            (40.0, 260.0),
        ] {
            out = out.or(d.push(at + dt, 0.0, y));
        }
        out.expect("a beat")
    };
    let mut t = 1000.0;
    for _ in 0..6 {
        push_v(&mut d, t);
        t += 500.0;
    }
    assert!((d.bpm().unwrap() - 120.0).abs() < 1e-6);
    // A missed beat (a double interval), then a fermata (3 s), then on at 120.
    t += 500.0;
    let b = push_v(&mut d, t);
    assert!((b.bpm.unwrap() - 120.0).abs() < 1e-6, "{:?}", b.bpm);
    t += 3000.0;
    let b = push_v(&mut d, t);
    assert!((b.bpm.unwrap() - 120.0).abs() < 1e-6, "{:?}", b.bpm);
    assert!((d.next_beat_ms().unwrap() - (t + 500.0)).abs() < 1e-6);
    // A real change wins once two intervals agree: 100 BPM.
    for _ in 0..3 {
        t += 600.0;
        push_v(&mut d, t);
    }
    assert!(
        (d.bpm().unwrap() - 100.0).abs() < 1.0,
        "{:?} {:?}",
        d.bpm(),
        d
    );
}

#[test]
fn a_wobble_or_a_baton_held_still_makes_no_beat() {
    let mut d = BeatDetector::new(BeatParams::default());
    let mut rng = orch_baton::synth::Rng::new(5);
    for i in 0..600 {
        let t = i as f64 * 1000.0 / 60.0;
        let y = 200.0 + 6.0 * (t / 90.0).sin() + 1.5 * rng.normal();
        assert_eq!(d.push(t, 0.0, y), None, "at {t}");
    }
}

#[test]
fn one_sample_after_the_bottom_is_enough_when_the_rest_are_lost() {
    // A sharp V whose rebound leaves the picture (seen only while y ≥ 190): one sample after
    // each bottom, then nothing until the next downstroke comes back in.
    let ictus: Vec<f64> = (0..8).map(|k| 500.0 + 600.0 * k as f64).collect();
    let path = |t: f64| {
        let k = ictus.partition_point(|&i| i <= t);
        let after = if k == 0 {
            f64::INFINITY
        } else {
            t - ictus[k - 1]
        };
        let before = ictus.get(k).map_or(f64::INFINITY, |&i| i - t);
        (300.0 - 3.0 * after).max(300.0 - 1.5 * before)
    };
    let mut d = BeatDetector::new(BeatParams::default());
    let mut found = Vec::new();
    for i in 0..160 {
        let t = i as f64 * 1000.0 / 30.0;
        let y = path(t);
        if y >= 190.0 {
            found.extend(d.push(t, 0.0, y));
        }
    }
    assert_eq!(found.len(), ictus.len(), "{found:#?}");
    for (b, &i) in found.iter().zip(&ictus) {
        assert!(
            (b.t_ms - i).abs() < 1000.0 / 30.0,
            "{} vs {i}: {found:?}",
            b.t_ms
        );
    }
}
