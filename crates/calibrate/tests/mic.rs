//! The live capture through ALSA without a sound card: ALSA's `file` plugin plays a synthetic
//! recording of the calibration score as a microphone (`infile`: raw frames in the format the
//! capture negotiates, over the `null` plugin, which takes any). The PCMs are defined in an
//! `asoundrc` of the test's own, which alsa.conf loads from `$XDG_CONFIG_HOME/alsa/asoundrc`.
#![cfg(feature = "mic")]

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use orch_calibrate::live::{take, TakeError, START_MARGIN, TAIL};
use orch_calibrate::mic::{Mic, MicError, MicFormat, SampleFormat};
use orch_calibrate::synthetic::{
    duty, file_mic_conf, hidden_robot, raw_s32, record, s32, HiddenKey, Room,
};
use orch_calibrate::{analyze, Anchor, Score};
use orch_robot::Robot;

/// Five keys (the fewest whose sync figure never strikes one key twice running).
const FIVE: &str =
    "[keys]\nlow = 60\nhigh = 64\n[[boards]]\nkind = \"pca9685\"\naddress = 0x40\nkeys = 5\n";
const LEVELS: u32 = 2;
const RATE: u32 = 48_000;
/// The recording's first sample, before the score's time 0.
const OFFSET_MS: f64 = 300.0;

struct Fixture {
    dir: PathBuf,
    robot: Robot,
    score: Score,
    keys: Vec<HiddenKey>,
    /// The recording's samples as the capture reads them back (S32_LE, scaled).
    samples: Vec<f32>,
}

/// The recording, the raw files and the asoundrc: made once, before any ALSA call.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        // Under the target folder, not the system's temporary one: the same folder each run
        // (a fixture for every test of this process, it outlives them all).
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("orch-calibrate-mic");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("alsa")).unwrap();
        let robot = Robot::from_toml(FIVE).unwrap();
        let score = Score::for_robot(&robot, LEVELS).unwrap();
        let keys = hidden_robot(60, 64, (0.30, 0.50), 5);
        let room = Room {
            rate: RATE,
            capture_offset_ms: OFFSET_MS,
            snr_db: Some(40.0),
            reverb: false,
            thump: None,
            seed: 5,
        };
        let mut samples = record(&score, &robot, &keys, &room).samples;
        // As long as a take records (it asks for the score, the tail and a margin), and more.
        let take_s = f64::from(score.length_ms()) / 1000.0 + (TAIL + START_MARGIN).as_secs_f64();
        samples.resize(((take_s + 1.0) * f64::from(RATE)) as usize, 0.0);
        std::fs::write(dir.join("rec.raw"), raw_s32(&samples)).unwrap();
        // A microphone that stops: a FIFO that gets one second of it, then nothing (a file
        // would not do: at its end the plugin goes on giving the last samples read).
        // One for each test that uses it.
        for fifo in ["stops1.fifo", "stops2.fifo"] {
            let status = std::process::Command::new("mkfifo")
                .arg(dir.join(fifo))
                .status()
                .unwrap();
            assert!(status.success());
        }
        let pcm = |name: &str, file: &str| file_mic_conf(name, &dir.join(file));
        std::fs::write(
            dir.join("alsa/asoundrc"),
            pcm("calmic", "rec.raw")
                + &pcm("calstops1", "stops1.fifo")
                + &pcm("calstops2", "stops2.fifo")
                // Devices of one rate: the file behind ALSA's `plug` with its slave's rate
                // fixed (with resampling off, as the capture asks, the plug keeps it).
                + &pcm("calfile", "rec.raw")
                + "pcm.calmic44 { type plug; slave { pcm \"calfile\"; rate 44100 } }\n"
                + "pcm.calmic8k { type plug; slave { pcm \"calfile\"; rate 8000 } }\n",
        )
        .unwrap();
        // Before the first ALSA call of the process (alsa-lib reads its configuration once),
        // and every test comes through here first.
        std::env::set_var("XDG_CONFIG_HOME", &dir);
        let samples = samples
            .iter()
            .map(|&x| s32(x) as f32 / 2_147_483_648.0)
            .collect();
        Fixture {
            dir,
            robot,
            score,
            keys,
            samples,
        }
    })
}

/// Feeds the FIFO microphone one second of the recording once it is opened, then holds it
/// open with nothing more until the returned sender is dropped.
fn feed_one_second(f: &Fixture, fifo: &str) -> std::sync::mpsc::Sender<()> {
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    let (path, second) = (f.dir.join(fifo), f.samples[..RATE as usize].to_vec());
    std::thread::spawn(move || {
        use std::io::Write;
        // Opening blocks until the plugin opens its end.
        let mut fifo = std::fs::OpenOptions::new().write(true).open(path).unwrap();
        let _ = fifo.write_all(&raw_s32(&second));
        let _ = rx.recv();
    });
    tx
}

/// `f()` on a thread of its own, given `limit`: one that hangs fails the test rather than
/// hanging it.
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("still running after {limit:?}: hung"))
}

#[test]
fn the_microphone_delivers_the_recording_sample_for_sample() {
    let f = fixture();
    let mic = Mic::open("calmic").unwrap();
    assert_eq!(
        mic.format(),
        MicFormat {
            format: SampleFormat::S32,
            rate: RATE,
            channels: 1
        }
    );
    let seconds = 3.0;
    let captured = mic.start(seconds).unwrap().finish().unwrap();
    let n = (seconds * f64::from(RATE)) as usize;
    assert_eq!(captured.recording.rate, RATE);
    assert_eq!(captured.recording.samples.len(), n);
    assert!(
        captured.recording.samples == f.samples[..n],
        "the capture read other samples than the file holds"
    );
    // Not silence: the sync figure's first strike is in the first 3 s.
    assert!(captured.recording.samples.iter().any(|x| x.abs() > 0.01));
}

#[test]
fn a_device_without_48_khz_is_recorded_at_44_1_khz_not_resampled() {
    let f = fixture();
    let mic = Mic::open("calmic44").unwrap();
    assert_eq!(
        mic.format(),
        MicFormat {
            format: SampleFormat::S32,
            rate: 44_100,
            channels: 1
        }
    );
    let captured = mic.start(1.0).unwrap().finish().unwrap();
    assert_eq!(captured.recording.rate, 44_100);
    assert!(
        captured.recording.samples == f.samples[..44_100],
        "resampled, or not the file's samples"
    );
}

#[test]
fn a_device_whose_rates_are_too_low_is_refused_naming_its_rate() {
    fixture();
    let e = Mic::open("calmic8k").unwrap_err();
    assert!(matches!(e, MicError::Format { .. }), "{e:?}");
    assert!(e.is_bad_input());
    assert!(e.to_string().contains("8000 Hz"), "{e}");
}

#[test]
fn a_device_that_does_not_exist_is_named() {
    fixture();
    let e = Mic::open("orch_no_such_mic").unwrap_err();
    assert!(matches!(e, MicError::NoDevice { .. }), "{e:?}");
    assert!(e.is_bad_input());
    let text = e.to_string();
    assert!(
        text.contains("--mic orch_no_such_mic: no such capture device"),
        "{text}"
    );
    assert!(text.contains("arecord -L"), "{text}");
}

#[test]
fn a_microphone_that_stops_is_an_error_not_a_hang() {
    let f = fixture();
    let _feed = feed_one_second(f, "stops1.fifo");
    let t = Instant::now();
    let e = within(Duration::from_secs(10), || {
        Mic::open("calstops1")
            .unwrap()
            .start(10.0)
            .unwrap()
            .finish()
    })
    .unwrap_err();
    match e {
        // About where the sound stopped (a short read from the FIFO still counts whole).
        MicError::Stalled { at_s, .. } => assert!((0.95..1.5).contains(&at_s), "{at_s}"),
        e => panic!("{e:?}"),
    }
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
}

#[test]
fn a_failing_microphone_stops_the_performance() {
    let f = fixture();
    let _feed = feed_one_second(f, "stops2.fifo");
    let t = Instant::now();
    let e = within(Duration::from_secs(30), || {
        let out = orch_io::OutSpec::parse("sim").unwrap();
        let mic = Mic::open("calstops2").unwrap();
        take(&f.robot, &f.score, out, mic, &AtomicBool::new(false))
    })
    .unwrap_err();
    assert!(
        matches!(e, TakeError::Mic(MicError::Stalled { .. })),
        "{e:?}"
    );
    assert!(e.to_string().contains("every key released"), "{e}");
    // Stopped at the stall (2 s), not played to the end of the score.
    assert!(
        t.elapsed() < Duration::from_secs(5),
        "{:?} (the score is {} ms)",
        t.elapsed(),
        f.score.length_ms()
    );
}

#[test]
fn an_output_without_channel_1_is_refused_before_anything_plays() {
    let f = fixture();
    let out = orch_io::OutSpec::parse("sim:ch=2-16").unwrap();
    let e = take(
        &f.robot,
        &f.score,
        out,
        Mic::open("calmic").unwrap(),
        &AtomicBool::new(false),
    )
    .unwrap_err();
    assert!(e.is_bad_input(), "{e:?}");
    assert!(e.to_string().contains("channel 1"), "{e}");
}

#[test]
fn a_take_on_the_virtual_robot_recovers_the_hidden_delays() {
    let f = fixture();
    let out = orch_io::OutSpec::parse("sim").unwrap();
    let mut t = take(
        &f.robot,
        &f.score,
        out,
        Mic::open("calmic").unwrap(),
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!(t.format.rate, RATE);
    // A file read as fast as it goes is no sound card: no clock to measure.
    assert_eq!(t.clock_ppm, None);
    // The stream started just before the performance: a few ms cut off the front.
    assert!((0.0..200.0).contains(&t.lead_ms), "{}", t.lead_ms);
    assert_eq!(t.played.records.len(), f.score.schedule().len());
    // Lined up: the take begins where the score's time 0 fell in the stream.
    let cut = (t.lead_ms * f64::from(RATE) / 1000.0).round() as usize;
    assert!(
        t.recording.samples[..1000] == f.samples[cut..cut + 1000],
        "the take does not begin {} ms into the stream",
        t.lead_ms
    );
    let anchor = Anchor {
        note: 60,
        press_delay_ms: f.keys[0].press_delay_ms,
    };
    let cal = analyze(&t.recording, &f.robot, &f.score, Some(anchor)).unwrap();
    // The file's offset less what was cut (the analysis's bias of a fraction of a ms aside).
    assert!(
        (cal.capture_offset_ms - (OFFSET_MS - t.lead_ms)).abs() < 3.0,
        "{} vs {} - {}",
        cal.capture_offset_ms,
        OFFSET_MS,
        t.lead_ms
    );
    for (k, hidden) in cal.keys.iter().zip(&f.keys) {
        let loud = k.levels.iter().find(|l| l.velocity == 127).unwrap();
        let want = hidden.delay_at(duty(&f.robot, k.note, 127));
        let got = loud.press_delay_ms.unwrap_or(f64::NAN);
        assert!(
            (got - want).abs() <= 1.0,
            "note {}: {got} vs {want}",
            k.note
        );
    }
    // What would spoil a take's timing is said: a late message, a sound card's clock off.
    t.priority_refused = false;
    t.played.lateness_us = Some(vec![300, 2_500, 40]);
    t.clock_ppm = Some(5.0);
    assert_eq!(
        t.warnings(),
        ["a message went out 2.5 ms late: the delays measured may be off by as much"]
    );
    t.played.lateness_us = Some(vec![300]);
    t.clock_ppm = Some(-25.0);
    let w = t.warnings();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("runs -25 ppm off the host's"), "{w:?}");
    assert!(w[0].contains("corrected"), "{w:?}");
}
