//! `orch calibrate --out OUT --mic DEVICE`: the score played and recorded at once. Without a
//! sound card: ALSA's `file` plugin plays a synthetic recording of the score as the
//! microphone, defined in an `asoundrc` of the test's own (alsa.conf loads
//! `$XDG_CONFIG_HOME/alsa/asoundrc`, set for the `orch` run alone). Built without the `mic`
//! feature, `--mic` is refused, naming it.

use std::process::Command;

fn orch() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orch"))
}

/// Five keys (the fewest whose sync figure never strikes one key twice running).
const FIVE: &str =
    "[keys]\nlow = 60\nhigh = 64\n[[boards]]\nkind = \"pca9685\"\naddress = 0x40\nkeys = 5\n";

fn dir(name: &str) -> testkit::Scratch {
    let d = testkit::Scratch::new(&format!("calibrate-mic-{name}"));
    std::fs::create_dir_all(d.join("alsa")).unwrap();
    std::fs::write(d.join("robot.toml"), FIVE).unwrap();
    d
}

#[cfg(not(feature = "mic"))]
#[test]
fn mic_without_the_feature_names_it() {
    let d = dir("nofeature");
    let out = orch()
        .args(["calibrate", "--out", "sim", "--mic", "default", "--robot"])
        .arg(d.join("robot.toml"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("without the `mic` feature"), "{err}");
    assert!(err.contains("--features mic"), "{err}");
}

#[test]
fn mic_needs_an_output_and_out_needs_a_mic() {
    let d = dir("args");
    for args in [
        &["--mic", "default"][..],
        &["--out", "sim", "--wav", "x.wav"][..],
        &["--keep", "k.wav", "--wav", "x.wav"][..],
        &["--mic", "default", "--out", "sim", "--wav", "x.wav"][..],
        &["--out", "sim", "--score", "x.mid"][..],
    ] {
        let out = orch()
            .arg("calibrate")
            .args(args)
            .arg("--robot")
            .arg(d.join("robot.toml"))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

#[cfg(feature = "mic")]
mod mic {
    use super::*;
    use orch_calibrate::synthetic::{
        file_mic_conf, hidden_robot, raw_s32, record, HiddenKey, Room,
    };
    use orch_calibrate::Score;
    use serde_json::Value;
    use std::path::Path;
    use std::time::{Duration, Instant};

    const RATE: u32 = 48_000;

    /// The robot, its score at 2 levels, the hidden keys, and the recording (padded to more
    /// than a take records).
    fn recording() -> (Vec<HiddenKey>, Vec<f32>) {
        let robot = orch_robot::Robot::from_toml(FIVE).unwrap();
        let score = Score::for_robot(&robot, 2).unwrap();
        let keys = hidden_robot(60, 64, (0.30, 0.50), 9);
        let room = Room {
            rate: RATE,
            capture_offset_ms: 250.0,
            snr_db: Some(40.0),
            reverb: false,
            thump: None,
            seed: 9,
        };
        let mut samples = record(&score, &robot, &keys, &room).samples;
        samples.resize(
            (f64::from(score.length_ms()) / 1000.0 + 4.0) as usize * RATE as usize,
            0.0,
        );
        (keys, samples)
    }

    fn with_mic(cmd: &mut Command, d: &Path) {
        cmd.env("XDG_CONFIG_HOME", d);
    }

    /// `calmic` in `d`'s asoundrc: a microphone that plays `samples`.
    fn mic_playing(d: &Path, samples: &[f32]) {
        std::fs::write(d.join("rec.raw"), raw_s32(samples)).unwrap();
        std::fs::write(
            d.join("alsa/asoundrc"),
            file_mic_conf("calmic", &d.join("rec.raw")),
        )
        .unwrap();
    }

    /// What an output sends last when it lets go of every key.
    fn all_notes_off() -> Vec<u8> {
        (0..16u8).flat_map(|c| [0xB0 | c, 123, 0]).collect()
    }

    #[test]
    fn calibrate_mic_plays_records_and_prints_the_measurements() {
        let d = dir("take");
        let (keys, samples) = recording();
        mic_playing(&d, &samples);
        let anchor = format!("60={:.3}", keys[0].press_delay_ms);
        let mut cmd = orch();
        cmd.args([
            "calibrate",
            "--out",
            "sim",
            "--mic",
            "calmic",
            "--levels",
            "2",
        ])
        .arg("--robot")
        .arg(d.join("robot.toml"))
        .args(["--anchor", &anchor, "--json", "--keep"])
        .arg(d.join("kept.wav"));
        with_mic(&mut cmd, &d);
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(
            err.contains("recording it from --mic calmic (S32_LE, 48000 Hz, mono)"),
            "{err}"
        );
        assert!(err.contains("capture offset"), "{err}");
        let json: Value = serde_json::from_slice(&out.stdout).unwrap();
        let keys_json = json["keys"].as_array().unwrap();
        assert_eq!(keys_json.len(), 5);
        let robot = orch_robot::Robot::from_toml(FIVE).unwrap();
        for (k, hidden) in keys_json.iter().zip(&keys) {
            let note = k["note"].as_u64().unwrap() as u8;
            let loud = k["levels"]
                .as_array()
                .unwrap()
                .iter()
                .find(|l| l["velocity"] == 127)
                .unwrap();
            let got = loud["press_delay_ms"].as_f64().unwrap();
            let want = hidden.delay_at(orch_calibrate::synthetic::duty(&robot, note, 127));
            assert!((got - want).abs() <= 1.0, "note {note}: {got} vs {want}");
        }
        // The kept take analyses to the same figures, and as a robot.toml that loads.
        let kept = |json: bool| {
            let out = orch()
                .args(["calibrate", "--levels", "2", "--anchor", &anchor])
                .args(json.then_some("--json"))
                .arg("--robot")
                .arg(d.join("robot.toml"))
                .arg("--wav")
                .arg(d.join("kept.wav"))
                .output()
                .unwrap();
            assert!(out.status.success());
            out.stdout
        };
        let again: Value = serde_json::from_slice(&kept(true)).unwrap();
        assert_eq!(again["keys"], json["keys"]);
        let toml = kept(false);
        orch_robot::Robot::from_toml(&String::from_utf8(toml).unwrap()).unwrap();
    }

    #[test]
    fn calibrate_mic_names_a_device_that_does_not_exist_before_the_robot_moves() {
        let d = dir("nodevice");
        let raw = d.join("raw.bin");
        std::fs::write(&raw, b"").unwrap();
        let mut cmd = orch();
        cmd.args(["calibrate", "--mic", "orch_no_such_mic", "--out"])
            .arg(format!("rawmidi:{}", raw.display()))
            .arg("--robot")
            .arg(d.join("robot.toml"));
        with_mic(&mut cmd, &d);
        let out = cmd.output().unwrap();
        assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--mic orch_no_such_mic: no such capture device"),
            "{err}"
        );
        assert!(err.contains("arecord -L"), "{err}");
        assert_eq!(std::fs::read(&raw).unwrap(), b"", "the output was used");
    }

    #[test]
    fn sigterm_stops_the_take_with_every_key_released() {
        let d = dir("sigterm");
        let (_, samples) = recording();
        mic_playing(&d, &samples);
        let raw = d.join("raw.bin");
        std::fs::write(&raw, b"").unwrap();
        let mut cmd = orch();
        cmd.args(["calibrate", "--mic", "calmic", "--levels", "2", "--out"])
            .arg(format!("rawmidi:{}", raw.display()))
            .arg("--robot")
            .arg(d.join("robot.toml"))
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped());
        with_mic(&mut cmd, &d);
        let child = cmd.spawn().unwrap();
        // The sync figure's first strike (1 s in) has gone out.
        let t = Instant::now();
        while !std::fs::read(&raw).unwrap().contains(&0x90) {
            assert!(t.elapsed() < Duration::from_secs(10), "nothing played");
            std::thread::sleep(Duration::from_millis(20));
        }
        nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(child.id() as i32),
            nix::sys::signal::Signal::SIGTERM,
        )
        .unwrap();
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("stopped before the end of the score"), "{err}");
        assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
        let bytes = std::fs::read(&raw).unwrap();
        assert!(bytes.ends_with(&all_notes_off()), "{bytes:02x?}");
    }

    #[test]
    fn a_microphone_that_stops_stops_the_robot_with_every_key_released() {
        let d = dir("stops");
        let (_, samples) = recording();
        let fifo = d.join("mic.fifo");
        let _ = std::fs::remove_file(&fifo);
        assert!(Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success());
        std::fs::write(d.join("alsa/asoundrc"), file_mic_conf("calstops", &fifo)).unwrap();
        // Two seconds of sound (the sync figure begins), then nothing, the FIFO held open.
        // Opened for reading too, so that opening never waits for orch; left behind if orch
        // never reads it.
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        std::thread::spawn(move || {
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(fifo)
                .unwrap();
            let _ = f.write_all(&raw_s32(&samples[..2 * RATE as usize]));
            let _ = rx.recv();
        });
        let raw = d.join("raw.bin");
        std::fs::write(&raw, b"").unwrap();
        let t = Instant::now();
        let mut cmd = orch();
        cmd.args(["calibrate", "--mic", "calstops", "--levels", "2", "--out"])
            .arg(format!("rawmidi:{}", raw.display()))
            .arg("--robot")
            .arg(d.join("robot.toml"));
        with_mic(&mut cmd, &d);
        let out = cmd.output().unwrap();
        drop(tx);
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("stopped delivering sound"), "{err}");
        assert!(err.contains("every key released"), "{err}");
        // Stopped at the stall, long before the score's 16 s.
        assert!(t.elapsed() < Duration::from_secs(8), "{:?}", t.elapsed());
        let bytes = std::fs::read(&raw).unwrap();
        assert!(bytes.contains(&0x90), "no note was played: {bytes:02x?}");
        assert!(bytes.ends_with(&all_notes_off()), "{bytes:02x?}");
    }
}
