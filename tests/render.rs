//! `orch render` end to end: the WAV's strikes, found in its samples, against the report and
//! the note-by-note account of `orch analyze`; loudness on a PWM robot; bad input.
//!
//! Needs a soundfont where Debian puts them (the test command installs
//! `timgm6mb-soundfont`): its notes begin with up to 7 ms of silence, which the renderer
//! takes off each strike's start, so each strike's first sound is found on the virtual
//! robot's sample.

use std::path::{Path, PathBuf};
use std::process::Command;

use orch_render::{onset, wav};
use serde_json::Value;

const RATE: f64 = 44_100.0;

fn orch() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orch"))
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("orch-render-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A one-track file, 480 ticks a quarter at 120 bpm (0.96 tick a ms): `(ms, note, velocity,
/// length ms)`.
fn smf(notes: &[(u32, u8, u8, u32)]) -> Vec<u8> {
    let mut ev: Vec<(u32, [u8; 3])> = Vec::new();
    for &(at, n, v, len) in notes {
        ev.push((at, [0x90, n, v]));
        ev.push((at + len, [0x80, n, 0]));
    }
    ev.sort_by_key(|e| e.0);
    let mut track = Vec::new();
    let mut last = 0;
    for (ms, bytes) in ev {
        let tick = ms * 96 / 100;
        let mut d = tick - last;
        last = tick;
        let mut var = vec![(d & 0x7F) as u8];
        d >>= 7;
        while d > 0 {
            var.insert(0, 0x80 | (d & 0x7F) as u8);
            d >>= 7;
        }
        track.extend_from_slice(&var);
        track.extend_from_slice(&bytes);
    }
    track.extend_from_slice(&[0, 0xFF, 0x2F, 0]);
    let mut f = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
    f.extend_from_slice(&(track.len() as u32).to_be_bytes());
    f.extend_from_slice(&track);
    f
}

fn config(boards: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let out = orch()
        .args(["config", "--boards", boards])
        .output()
        .unwrap();
    assert!(out.status.success());
    let path = tmp(&format!("robot-{boards}.toml"));
    std::fs::write(&path, edit(String::from_utf8(out.stdout).unwrap())).unwrap();
    path
}

fn render(midi: &Path, robot: &Path, score: bool, name: &str) -> (Vec<f32>, Vec<f32>) {
    let out = tmp(name);
    let mut c = orch();
    c.arg("render")
        .arg(midi)
        .arg("-o")
        .arg(&out)
        .arg("--robot")
        .arg(robot);
    if score {
        c.arg("--score");
    }
    let o = c.output().unwrap();
    assert!(
        o.status.success(),
        "orch render: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (l, r, rate) = wav::read(&out).unwrap();
    assert_eq!(f64::from(rate), RATE);
    (l, r)
}

/// The note-by-note account of `orch analyze`.
fn account(midi: &Path, robot: &Path) -> Vec<Value> {
    // A file of each test's own (they run at once in this process).
    let stem = midi.file_stem().unwrap().to_string_lossy();
    let notes = tmp(&format!("{stem}.notes.jsonl"));
    let o = orch()
        .arg("analyze")
        .arg(midi)
        .arg("--robot")
        .arg(robot)
        .arg("--notes")
        .arg(&notes)
        .output()
        .unwrap();
    assert!(o.status.success());
    std::fs::read_to_string(&notes)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn sample(ms: f64) -> i64 {
    (ms * RATE / 1000.0).round() as i64
}

/// Onsets: the first sample that is not digital silence after at least 50 ms of it.
fn onsets(l: &[f32], r: &[f32]) -> Vec<i64> {
    onset::onsets(l, r, 0.0, RATE as usize / 20)
        .into_iter()
        .map(|i| i as i64)
        .collect()
}

fn near(onsets: &[i64], at: i64, within: i64) -> Option<i64> {
    onsets.iter().copied().find(|o| (o - at).abs() <= within)
}

#[test]
fn the_robot_and_the_score_differ_exactly_where_the_report_says() {
    // Single notes 2.5 s apart (the font's release dies away between), at full velocity (the
    // loudness of the thesis's on/off keys); note 20 is below the keys and the robot drops it.
    let notes: Vec<(u32, u8, u8, u32)> = [48u8, 60, 20, 67, 72, 55, 84]
        .iter()
        .enumerate()
        .map(|(i, &n)| (400 + 2500 * i as u32 + 13 * i as u32, n, 127, 150))
        .collect();
    let midi = tmp("sparse.mid");
    std::fs::write(&midi, smf(&notes)).unwrap();
    let robot = config("pca9555", |t| {
        t.replace("out_of_range = \"fold\"", "out_of_range = \"drop\"")
    });
    let lines = account(&midi, &robot);
    assert_eq!(lines.len(), notes.len());
    let (sl, sr) = render(&midi, &robot, true, "score.wav");
    let (rl, rr) = render(&midi, &robot, false, "robot.wav");
    let (score, played) = (onsets(&sl, &sr), onsets(&rl, &rr));
    assert_eq!(score.len(), notes.len(), "the score: every note {score:?}");
    let sounded = lines.iter().filter(|l| l["sounded_ms"].is_f64()).count();
    assert_eq!(played.len(), sounded, "the robot: every strike {played:?}");
    assert_eq!(sounded, notes.len() - 1);
    for line in &lines {
        let t = line["t_ms"].as_f64().unwrap();
        let s = near(&score, sample(t), 1).expect("the score's onset on its sample");
        match line["sounded_ms"].as_f64() {
            Some(h) => {
                let p = near(&played, sample(h), 1).unwrap_or_else(|| {
                    panic!("no onset within a sample of the robot's strike at {h} ms: {played:?}")
                });
                let want = sample(h) - sample(t);
                assert!(
                    ((p - s) - want).abs() <= 1,
                    "note at {t} ms: the robot's onset is {} samples after the score's, the \
                     account says {want}",
                    p - s
                );
            }
            None => {
                assert_eq!(line["reason"], "range");
                assert_eq!(near(&played, sample(t), sample(500.0)), None);
                let at = sample(t) as usize;
                assert_eq!(onset::rms(&rl, &rr, at, at + RATE as usize), 0.0);
            }
        }
    }
    // Nothing clips; there is sound.
    let peak = rl.iter().chain(&rr).fold(0f32, |m, x| m.max(x.abs()));
    assert!(peak > 0.01 && peak < 1.0, "peak {peak}");
}

#[test]
fn on_a_pwm_robot_a_soft_note_is_softer_than_a_loud_one_and_a_too_soft_one_is_silent() {
    // The keys need 60 % to throw the hammer, the dynamics strike velocity 1 at 45 %: too soft.
    let robot = config("pca9685", |t| {
        t.replace(
            "softest = \"45%\"\nsoft_press_delay",
            "softest = \"60%\"\nsoft_press_delay",
        )
    });
    let notes = [(400, 60, 40, 300), (3000, 60, 120, 300), (5600, 60, 1, 300)];
    let midi = tmp("dynamics.mid");
    std::fs::write(&midi, smf(&notes)).unwrap();
    let lines = account(&midi, &robot);
    assert_eq!(lines[2]["reason"], "too_soft", "{:?}", lines[2]);
    let heard: Vec<u64> = lines[..2]
        .iter()
        .map(|l| l["sounded_velocity"].as_u64().unwrap())
        .collect();
    assert!(heard[0] < heard[1], "{heard:?}");
    let (l, r) = render(&midi, &robot, false, "dynamics.wav");
    let found = onsets(&l, &r);
    assert_eq!(found.len(), 2, "{found:?}");
    let loudness: Vec<f32> = found
        .iter()
        .map(|&o| onset::rms(&l, &r, o as usize, o as usize + RATE as usize / 4))
        .collect();
    assert!(
        loudness[0] < loudness[1] * 0.7,
        "velocity {} → RMS {}, velocity {} → RMS {}",
        heard[0],
        loudness[0],
        heard[1],
        loudness[1]
    );
    let at = sample(5600.0) as usize;
    assert_eq!(onset::rms(&l, &r, at, at + RATE as usize), 0.0);
}

#[test]
fn a_missing_soundfont_or_an_unreadable_midi_file_is_bad_input() {
    let midi = tmp("one.mid");
    std::fs::write(&midi, smf(&[(0, 60, 100, 100)])).unwrap();
    let o = orch()
        .arg("render")
        .arg(&midi)
        .args(["-o", tmp("x.wav").to_str().unwrap()])
        .args(["--soundfont", "/nonexistent/piano.sf2"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("/nonexistent/piano.sf2") && err.contains("no such file"),
        "{err}"
    );

    let junk = tmp("junk.mid");
    std::fs::write(&junk, b"not a midi file at all").unwrap();
    let o = orch()
        .arg("render")
        .arg(&junk)
        .args(["-o", tmp("y.wav").to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );

    let o = orch()
        .arg("render")
        .arg(&midi)
        .args(["-o", tmp("z.wav").to_str().unwrap()])
        .args(["--soundfont", junk.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a SoundFont"));
}
