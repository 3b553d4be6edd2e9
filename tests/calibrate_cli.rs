//! `orch calibrate`: the score written, a synthetic recording read back into a robot.toml
//! that loads (and its measurements as JSON), bad recordings refused with exit 2.

use assert_cmd::Command;
use orch_calibrate::synthetic::{clear_of_floor, hidden_robot, record, Room};
use orch_calibrate::Score;
use testkit::Scratch;

const SMALL: &str =
    "[keys]\nlow = 60\nhigh = 71\n[[boards]]\nkind = \"pca9685\"\naddress = 0x40\nkeys = 12\n";

fn dir(name: &str) -> Scratch {
    let d = Scratch::new(&format!("calibrate-{name}"));
    std::fs::write(d.join("robot.toml"), SMALL).unwrap();
    d
}

fn orch() -> Command {
    Command::cargo_bin("orch").unwrap()
}

#[test]
fn calibrate_score_writes_every_key_at_every_level_after_the_sync_figure() {
    let d = dir("score");
    orch()
        .args(["calibrate", "--score"])
        .arg(d.join("cal.mid"))
        .arg("--robot")
        .arg(d.join("robot.toml"))
        .args(["--levels", "3"])
        .assert()
        .success()
        .stderr(predicates::str::contains(
            "12 keys at 3 levels ([1, 64, 127])",
        ));
    let bytes = std::fs::read(d.join("cal.mid")).unwrap();
    let smf = midly::Smf::parse(&bytes).unwrap();
    let ons = smf.tracks[0]
        .iter()
        .filter(|e| {
            matches!(
                e.kind,
                midly::TrackEventKind::Midi {
                    message: midly::MidiMessage::NoteOn { .. },
                    ..
                }
            )
        })
        .count();
    assert_eq!(ons, 5 + 12 * 3);
}

#[test]
fn calibrate_wav_prints_a_robot_toml_that_loads_and_json_measurements() {
    let d = dir("wav");
    let robot = orch_robot::Robot::from_toml(SMALL).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let mut keys = hidden_robot(60, 71, (0.40, 0.75), 2);
    clear_of_floor(&mut keys, &score, &robot, 12.0);
    let room = Room {
        rate: 48_000,
        capture_offset_ms: 800.0,
        snr_db: Some(30.0),
        reverb: true,
        thump: None,
        seed: 2,
    };
    let rec = record(&score, &robot, &keys, &room);
    rec.write(std::fs::File::create(d.join("rec.wav")).unwrap())
        .unwrap();
    let anchor = format!("60={:.3}", keys[0].press_delay_ms);
    let out = orch()
        .args(["calibrate", "--wav"])
        .arg(d.join("rec.wav"))
        .arg("--robot")
        .arg(d.join("robot.toml"))
        .args(["--anchor", &anchor])
        .assert()
        .success();
    let text = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    let calibrated = orch_robot::Robot::from_toml(&text).unwrap();
    for (i, k) in keys.iter().enumerate() {
        let m = calibrated.mechanics.for_key(i as u8);
        let got = m.press_delay.as_micros() as f64 / 1000.0;
        assert!(
            (got - k.press_delay_ms).abs() < 1.0,
            "key {i}: {got} vs {k:?}"
        );
    }
    assert!(text.contains("pinned by the anchor"), "{text}");
    let out = orch()
        .args(["calibrate", "--json", "--wav"])
        .arg(d.join("rec.wav"))
        .arg("--robot")
        .arg(d.join("robot.toml"))
        .assert()
        .success()
        .stderr(predicates::str::contains("relative to note 60"));
    let v: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
    assert!(v["capture_offset_ms"].is_number());
    let keys_json = v["keys"].as_array().unwrap();
    assert_eq!(keys_json.len(), 12);
    let k = &keys_json[0];
    assert_eq!(k["note"], 60);
    assert_eq!(k["levels"].as_array().unwrap().len(), 4);
    assert!(k["levels"][3]["press_delay_ms"].is_number());
    assert!(k["levels"][3]["level_db"].is_number());
    assert!(k["softest_velocity"].is_number());
    assert!(k["problems"].is_array());
}

#[test]
fn calibrate_refuses_a_bad_recording_with_exit_2_and_no_robot_toml() {
    let d = dir("bad");
    std::fs::write(d.join("not.wav"), b"hello, not a wav").unwrap();
    orch()
        .args(["calibrate", "--wav"])
        .arg(d.join("not.wav"))
        .assert()
        .code(2)
        .stdout("")
        .stderr(predicates::str::contains("not a WAV file"));
    let silent = orch_calibrate::Recording::from_samples(44_100, vec![0.0; 44_100 * 300]);
    silent
        .write(std::fs::File::create(d.join("silent.wav")).unwrap())
        .unwrap();
    orch()
        .args(["calibrate", "--wav"])
        .arg(d.join("silent.wav"))
        .assert()
        .code(2)
        .stdout("")
        .stderr(predicates::str::contains("silent"));
    orch()
        .args(["calibrate", "--wav"])
        .arg(d.join("silent.wav"))
        .args(["--anchor", "sixty"])
        .assert()
        .code(2)
        .stderr(predicates::str::contains("NOTE=MS"));
}

#[test]
fn calibrate_a_drum_kit_writes_its_score_and_fits_each_outputs_flight() {
    use orch_calibrate::synthetic::kit;
    let d = dir("drums");
    let text =
        orch_robot::instrument_toml(orch_robot::Instrument::Drums, orch_robot::BoardKind::Pwm);
    std::fs::write(d.join("kit.toml"), &text).unwrap();
    orch()
        .args(["calibrate", "--score"])
        .arg(d.join("kit.mid"))
        .arg("--robot")
        .arg(d.join("kit.toml"))
        .assert()
        .success()
        .stderr(predicates::str::contains("9 strike outputs at 4 levels"));
    let robot = orch_robot::Robot::from_toml(&text).unwrap();
    let score = Score::for_robot(&robot, 4).unwrap();
    let hidden = kit::hidden_outputs(&score, &robot, 5);
    let room = Room {
        rate: 48_000,
        capture_offset_ms: 600.0,
        snr_db: Some(30.0),
        reverb: true,
        thump: None,
        seed: 5,
    };
    kit::record(&score, &robot, &[], &hidden, &room)
        .write(std::fs::File::create(d.join("kit.wav")).unwrap())
        .unwrap();
    let out = orch()
        .args(["calibrate", "--wav"])
        .arg(d.join("kit.wav"))
        .arg("--robot")
        .arg(d.join("kit.toml"))
        .args([
            "--anchor",
            &format!("38={:.3}", hidden[1].beater.press_delay_ms),
        ])
        .assert()
        .success();
    let toml = String::from_utf8(out.get_output().stdout.clone()).unwrap();
    let calibrated = orch_robot::Robot::from_toml(&toml).unwrap();
    for (o, h) in score.outputs.iter().zip(&hidden) {
        let got = calibrated.mechanics.for_key(o.key).press_delay.as_micros() as f64 / 1000.0;
        assert!(
            (got - h.beater.press_delay_ms).abs() < 0.6,
            "{}: {got} vs {:?}",
            o.name,
            h.beater
        );
    }
    assert!(toml.contains("drums: loudness at full power"), "{toml}");
}
