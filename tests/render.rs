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
    testkit::in_test(name)
}

/// A one-track file, 480 ticks a quarter at 120 bpm (0.96 tick a ms): `(ms, note, velocity,
/// length ms)`, on channel 1.
fn smf(notes: &[(u32, u8, u8, u32)]) -> Vec<u8> {
    let on_1: Vec<(u32, u8, u8, u8, u32)> = notes
        .iter()
        .map(|&(at, n, v, len)| (at, 0, n, v, len))
        .collect();
    smf_on(&on_1)
}

/// The same with each note's channel (0-based: 9 is General MIDI's drums): `(ms, channel,
/// note, velocity, length ms)`.
fn smf_on(notes: &[(u32, u8, u8, u8, u32)]) -> Vec<u8> {
    let mut ev: Vec<(u32, Vec<u8>)> = Vec::new();
    for &(at, ch, n, v, len) in notes {
        ev.push((at, vec![0x90 | ch, n, v]));
        ev.push((at + len, vec![0x80 | ch, n, 0]));
    }
    ev.sort_by_key(|e| e.0);
    let at: Vec<(u64, Vec<u8>)> = ev
        .into_iter()
        .map(|(ms, bytes)| (u64::from(ms) * 96 / 100, bytes))
        .collect();
    testkit::smf::at_ticks(&at)
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

/// `orch config --instrument NAME`, written to a file.
fn instrument(name: &str) -> PathBuf {
    let out = orch()
        .args(["config", "--instrument", name])
        .output()
        .unwrap();
    assert!(out.status.success());
    let path = tmp(&format!("robot-{name}.toml"));
    std::fs::write(&path, out.stdout).unwrap();
    path
}

/// The thesis's piano (keys 0..=60) with the drum kit of `orch config --instrument drums` on
/// a fifth board (keys 61..=69).
fn piano_and_drums() -> PathBuf {
    let piano = orch().arg("config").output().unwrap().stdout;
    let drums = String::from_utf8(
        orch()
            .args(["config", "--instrument", "drums"])
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    let kit = &drums[drums.find("[[boards]]").unwrap()..drums.find("[bus]").unwrap()];
    let text = format!(
        "{}\n{}",
        String::from_utf8(piano).unwrap(),
        kit.replace("address = 0x21", "address = 0x25")
    );
    let path = tmp("robot-piano-and-drums.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The power spectrum of the mono mix of `l`/`r` over `n` samples (a power of two) from
/// `from`, Hann-windowed: `n / 2` bins of `RATE / n` Hz.
fn spectrum(l: &[f32], r: &[f32], from: usize, n: usize) -> Vec<f64> {
    let mut re: Vec<f64> = (0..n)
        .map(|i| {
            let x = l
                .get(from + i)
                .zip(r.get(from + i))
                .map_or(0.0, |(a, b)| 0.5 * (f64::from(*a) + f64::from(*b)));
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
            x * w
        })
        .collect();
    let mut im = vec![0.0; n];
    fft(&mut re, &mut im);
    (0..n / 2).map(|k| re[k] * re[k] + im[k] * im[k]).collect()
}

/// An in-place radix-2 FFT (`re.len()` a power of two).
fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let a = -2.0 * std::f64::consts::PI / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (wr, wi) = ((a * k as f64).cos(), (a * k as f64).sin());
                let (p, q) = (start + k, start + k + len / 2);
                let (xr, xi) = (re[q] * wr - im[q] * wi, re[q] * wi + im[q] * wr);
                re[q] = re[p] - xr;
                im[q] = im[p] - xi;
                re[p] += xr;
                im[p] += xi;
            }
        }
        len <<= 1;
    }
}

/// The share of a spectrum's power (`n`-point) from `lo` to `hi` Hz.
fn band_share(power: &[f64], n: usize, lo: f64, hi: f64) -> f64 {
    let hz = RATE / n as f64;
    let total: f64 = power.iter().sum();
    let band: f64 = power
        .iter()
        .enumerate()
        .filter(|(k, _)| (lo..hi).contains(&(*k as f64 * hz)))
        .map(|(_, p)| p)
        .sum();
    band / total.max(1e-30)
}

/// The frequency of the strongest peak from `lo` to `hi` Hz (parabolic between bins).
fn peak_hz(power: &[f64], n: usize, lo: f64, hi: f64) -> f64 {
    let hz = RATE / n as f64;
    let k = (((lo / hz).ceil() as usize).max(1)..((hi / hz) as usize).min(power.len() - 1))
        .max_by(|&a, &b| power[a].total_cmp(&power[b]))
        .unwrap();
    let (a, b, c) = (power[k - 1].ln(), power[k].ln(), power[k + 1].ln());
    let shift = 0.5 * (a - c) / (a - 2.0 * b + c);
    (k as f64 + shift) * hz
}

fn midi_hz(note: u8) -> f64 {
    440.0 * 2f64.powf((f64::from(note) - 69.0) / 12.0)
}

/// A drum pattern on channel 10: a strike every 400 ms (plus a few ms, so strikes fall on many
/// sample positions), of drums that die away within that on TimGM6mb (a tom rings 1.3 to
/// 2.1 s: one, last).
const PATTERN: [(u8, &str); 9] = [
    (36, "kick"),
    (42, "closed hi-hat"),
    (38, "snare"),
    (42, "closed hi-hat"),
    (35, "kick"),
    (44, "pedal hi-hat"),
    (40, "snare"),
    (42, "closed hi-hat"),
    (45, "low tom"),
];

#[test]
fn a_drum_kit_strikes_where_the_robot_struck_and_a_kick_is_low_and_a_hi_hat_high() {
    let notes: Vec<(u32, u8, u8, u8, u32)> = PATTERN
        .iter()
        .enumerate()
        .map(|(i, &(n, _))| (300 + 400 * i as u32 + 7 * i as u32, 9, n, 100, 50))
        .collect();
    let midi = tmp("drums.mid");
    std::fs::write(&midi, smf_on(&notes)).unwrap();
    let robot = instrument("drums");
    let lines = account(&midi, &robot);
    let (l, r) = render(&midi, &robot, false, "drums.wav");
    let found = onsets(&l, &r);
    assert_eq!(found.len(), notes.len(), "one onset a strike: {found:?}");
    for (line, &o) in lines.iter().zip(&found) {
        let h = line["sounded_ms"].as_f64().expect("every drum sounds");
        assert!(
            (o - sample(h)).abs() <= 1,
            "{}: onset at sample {o}, the robot's strike at {}",
            line["note"],
            sample(h)
        );
        // Sounded by the robot flight later than sent, on its beat.
        assert!(h - line["sent_ms"].as_f64().unwrap() >= 9.0, "{line}");
    }
    // Each strike's first 93 ms: the kicks' power below 200 Hz, the hi-hats' above 5 kHz
    // (TimGM6mb: 99.7 % and 91 %); the two snares (38 acoustic, 40 electric: one output
    // plays both) each its own drum, as written (81 % and 20 % below 200 Hz).
    const N: usize = 4096;
    let share: Vec<(f64, f64)> = found
        .iter()
        .map(|&o| {
            let p = spectrum(&l, &r, o as usize, N);
            (
                band_share(&p, N, 0.0, 200.0),
                band_share(&p, N, 5000.0, RATE / 2.0),
            )
        })
        .collect();
    for (&(n, name), &(low, high)) in PATTERN.iter().zip(&share) {
        match n {
            35 | 36 => assert!(
                low > 0.9 && high < 0.01,
                "{name}: {low:.3} below 200 Hz, {high:.3} above 5 kHz"
            ),
            42 | 44 => assert!(
                high > 0.7 && low < 0.05,
                "{name}: {low:.3} below 200 Hz, {high:.3} above 5 kHz"
            ),
            _ => {}
        }
    }
    assert!(
        share[2].0 - share[6].0 > 0.3,
        "snares 38 and 40 alike: {share:?}"
    );
}

/// The power of `p` (`n`-point) within 35 cents of `f` Hz.
fn band_at(p: &[f64], n: usize, f: f64) -> f64 {
    let (lo, hi) = (f * 2f64.powf(-0.35 / 12.0), f * 2f64.powf(0.35 / 12.0));
    let hz = RATE / n as f64;
    p.iter()
        .enumerate()
        .filter(|(k, _)| (lo..hi).contains(&(*k as f64 * hz)))
        .map(|(_, x)| x)
        .sum()
}

fn db(x: f64) -> f64 {
    10.0 * x.max(1e-30).log10()
}

#[test]
fn a_glockenspiel_sounds_at_its_bars_pitch() {
    // G5, D6, G6, E7, C8, then G4 (below the bars: folded up an octave, to G5's bar) and
    // C9 (folded down to C8's).
    let played = [79u8, 86, 91, 100, 108, 67, 120];
    let bar = [79u8, 86, 91, 100, 108, 79, 108];
    let notes: Vec<(u32, u8, u8, u32)> = played
        .iter()
        .enumerate()
        .map(|(i, &n)| (300 + 1000 * i as u32 + 11 * i as u32, n, 100, 50))
        .collect();
    let midi = tmp("glockenspiel.mid");
    std::fs::write(&midi, smf(&notes)).unwrap();
    let robot = instrument("glockenspiel");
    let lines = account(&midi, &robot);
    let (l, r) = render(&midi, &robot, false, "glockenspiel.wav");
    let found = onsets(&l, &r);
    assert_eq!(
        found.first().copied(),
        Some(sample(lines[0]["sounded_ms"].as_f64().unwrap())),
        "the first bar on the robot's sample"
    );
    // 186 ms from 5 ms after each strike. A glockenspiel's bar rings at its pitch and at
    // about 2.8 and 5.4 times it (TimGM6mb's strongest partial is often the 5.4th): the
    // strongest peak within a semitone of the bar's pitch is within 35 cents of it (the
    // font's samples are 10 to 20 cents sharp), and is a strong partial (within 12 dB of
    // the strongest bin; measured -8 to +3 dB); a folded note sounds at its bar, not where it
    // was written (at least 20 dB less there).
    const N: usize = 8192;
    let semitone = 2f64.powf(1.0 / 12.0);
    for ((line, &want), &written) in lines.iter().zip(&bar).zip(&played) {
        let h = line["sounded_ms"].as_f64().expect("every bar sounds");
        let p = spectrum(&l, &r, (sample(h) + sample(5.0)) as usize, N);
        let f0 = midi_hz(want);
        let peak = peak_hz(&p, N, f0 / semitone, f0 * semitone);
        let cents = 1200.0 * (peak / f0).log2();
        let strong = db(band_at(&p, N, f0)) - db(p.iter().copied().fold(0.0, f64::max));
        assert!(
            cents.abs() < 35.0 && strong > -12.0,
            "note {written} on bar {want} ({f0:.1} Hz): peak at {peak:.1} Hz ({cents:.1} \
             cents), {strong:.1} dB against the strongest"
        );
        if written != want {
            let there = db(band_at(&p, N, midi_hz(written))) - db(band_at(&p, N, f0));
            assert!(
                there < -20.0,
                "note {written} sounds where written: {there:.1} dB"
            );
        }
    }
}

#[test]
fn a_piano_and_a_drum_kit_render_into_one_file() {
    // Piano notes (channel 1) and drums (channel 10) in turn, 1.5 s apart (a piano note's
    // release dies away within), on one robot: keys 0..=60 and the kit's 61..=69.
    let notes: Vec<(u32, u8, u8, u8, u32)> = vec![
        (300, 0, 60, 100, 200),
        (1811, 9, 36, 100, 50),
        (3322, 0, 72, 100, 200),
        (4833, 9, 42, 100, 50),
    ];
    let midi = tmp("piano-and-drums.mid");
    std::fs::write(&midi, smf_on(&notes)).unwrap();
    let robot = piano_and_drums();
    let lines = account(&midi, &robot);
    let keys: Vec<u64> = lines.iter().map(|l| l["key"].as_u64().unwrap()).collect();
    assert_eq!(
        keys,
        [24, 61, 36, 63],
        "the piano's keys, then the kit's kick and hi-hat"
    );
    let (l, r) = render(&midi, &robot, false, "piano-and-drums.wav");
    let found = onsets(&l, &r);
    assert_eq!(found.len(), notes.len(), "one onset a strike: {found:?}");
    const N: usize = 4096;
    for (line, &o) in lines.iter().zip(&found) {
        let h = line["sounded_ms"].as_f64().unwrap();
        assert!(
            (o - sample(h)).abs() <= 1,
            "onset {o}, the robot's {}",
            sample(h)
        );
        let p = spectrum(&l, &r, o as usize, N);
        let note = line["note"].as_u64().unwrap() as u8;
        let what = match note {
            // The piano at its key's pitch: a strong peak there (within 12 dB of the
            // strongest bin, which may be its octave).
            60 | 72 => {
                let f0 = midi_hz(note);
                let semitone = 2f64.powf(1.0 / 12.0);
                let f = peak_hz(&p, N, f0 / semitone, f0 * semitone);
                let strong = db(band_at(&p, N, f0)) - db(p.iter().copied().fold(0.0, f64::max));
                assert!(
                    (1200.0 * (f / f0).log2()).abs() < 35.0 && strong > -12.0,
                    "piano {note}: peak {f:.1} Hz, {strong:.1} dB against the strongest"
                );
                continue;
            }
            36 => band_share(&p, N, 0.0, 200.0),
            _ => band_share(&p, N, 5000.0, RATE / 2.0),
        };
        assert!(
            what > 0.7,
            "drum {note}: {what:.3} of its power in its band"
        );
    }
}

#[test]
fn a_closed_or_pedal_hi_hat_cuts_an_open_one_short() {
    // The hi-hat output open (46) then closed (42); open again, then the pedal's output (44).
    // An open hi-hat alone rings 2.5 s on TimGM6mb, a closed or pedal one under 100 ms: the
    // soundfont's exclusive class (42, 44 and 46: class 1) ends the open one at the closing
    // strike, on whichever synthesizer and channel each plays, as one synthesizer would.
    let notes = [
        (300, 9, 46, 100, 50),
        (800, 9, 42, 100, 50),
        (2000, 9, 46, 100, 50),
        (2500, 9, 44, 100, 50),
    ];
    let midi = tmp("hi-hat.mid");
    std::fs::write(&midi, smf_on(&notes)).unwrap();
    let robot = instrument("drums");
    let lines = account(&midi, &robot);
    let (l, r) = render(&midi, &robot, false, "hi-hat.wav");
    let sounded: Vec<usize> = lines
        .iter()
        .map(|l| sample(l["sounded_ms"].as_f64().unwrap()) as usize)
        .collect();
    // The open hi-hats come after silence; each closing strike on an open one's sound.
    let found = onsets(&l, &r);
    assert_eq!(found, [sounded[0] as i64, sounded[2] as i64]);
    let ms = |n: f64| sample(n) as usize;
    assert!(
        onset::rms(&l, &r, sounded[0], sounded[0] + ms(300.0)) > 1e-3,
        "the open hi-hat sounds"
    );
    for closing in [1, 3] {
        let quiet = onset::rms(
            &l,
            &r,
            sounded[closing] + ms(150.0),
            sounded[closing] + ms(1000.0),
        );
        assert_eq!(quiet, 0.0, "strike {closing}: silence 150 ms after it");
    }
}
