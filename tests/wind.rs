//! The recorder robot (`orch config --instrument recorder`) plays a melody worked by hand:
//! repeated notes, a leap across the register break, a chord, notes faster than its fingers.
//! Every note that sounds is on time within 1 ms; the others are dropped with their reason;
//! the account is the report; the robot ends with everything off.

use std::path::{Path, PathBuf};
use std::process::Command;
use testkit::Scratch;

use serde_json::Value;

fn orch() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orch"))
}

fn scratch(name: &str) -> Scratch {
    Scratch::new(&format!("wind-{name}"))
}

/// A one-track file at 120 bpm, 480 ticks a quarter (0.96 tick a ms): `(ms, note, length ms)`
/// on channel 1, velocity 100.
fn smf(notes: &[(u32, u8, u32)]) -> Vec<u8> {
    let mut ev: Vec<(u32, u8, Vec<u8>)> = Vec::new();
    for &(at, n, len) in notes {
        ev.push((at, 1, vec![0x90, n, 100]));
        ev.push((at + len, 0, vec![0x80, n, 0]));
    }
    ev.sort_by_key(|e| (e.0, e.1)); // a Note-Off before a Note-On at the same time
    let at: Vec<(u64, Vec<u8>)> = ev
        .into_iter()
        .map(|(ms, _, bytes)| (u64::from(ms) * 96 / 100, bytes))
        .collect();
    testkit::smf::at_ticks(&at)
}

fn recorder(dir: &Path) -> PathBuf {
    let out = orch()
        .args(["config", "--instrument", "recorder"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let path = dir.join("recorder.toml");
    std::fs::write(&path, out.stdout).unwrap();
    path
}

/// `orch play --fast --json --notes --writes`: the report, the account, the board writes.
fn play(robot: &Path, midi: &Path, dir: &Path) -> (Value, Vec<Value>, Vec<Value>) {
    let (notes, writes) = (dir.join("notes.jsonl"), dir.join("writes.jsonl"));
    let out = orch()
        .args(["play", "--fast", "--json", "--robot"])
        .arg(robot)
        .arg("--notes")
        .arg(&notes)
        .arg("--writes")
        .arg(&writes)
        .arg(midi)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = |p: &Path| -> Vec<Value> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    };
    (
        serde_json::from_slice(&out.stdout).unwrap(),
        lines(&notes),
        lines(&writes),
    )
}

#[test]
fn a_melody_worked_by_hand_sounds_on_time_and_the_rest_is_dropped_with_its_reason() {
    let dir = scratch("melody");
    // 0: C5, D5, D5 again, E5 (legato quarters); 2000: B5 to E6 across the register break
    // (thumb to pinch) and back; 3500: a chord C5 E5 G5 (G5 plays); 4500: four notes 20 ms
    // apart, faster than the fingers (the valve's 5 ms and their 30 ms): only the last sounds.
    let mut notes = vec![
        (0, 72, 500),
        (500, 74, 500),
        (1000, 74, 500),
        (1500, 76, 500),
        (2000, 83, 500),
        (2500, 88, 500),
        (3000, 83, 500),
        (3500, 72, 500),
        (3500, 76, 500),
        (3500, 79, 500),
    ];
    for (i, n) in [81u8, 83, 84, 86].into_iter().enumerate() {
        notes.push((4500 + 20 * i as u32, n, 20));
    }
    let midi = dir.join("melody.mid");
    std::fs::write(&midi, smf(&notes)).unwrap();
    let (report, lines, writes) = play(&recorder(&dir), &midi, &dir);
    let outcome = |i: usize| {
        let l = &lines[i];
        match l["outcome"].as_str().unwrap() {
            "dropped" => format!("dropped {}", l["reason"].as_str().unwrap()),
            o => o.to_string(),
        }
    };
    let got: Vec<String> = (0..lines.len()).map(outcome).collect();
    let want = [
        "on_time",
        "on_time",
        "on_time",
        "on_time",
        "on_time",
        "on_time",
        "on_time",
        "dropped monophonic",
        "dropped monophonic",
        "on_time",
        "dropped too_fast",
        "dropped too_fast",
        "dropped too_fast",
        "on_time",
    ];
    assert_eq!(got, want, "{lines:#?}");
    for l in lines.iter().filter(|l| l["outcome"] == "on_time") {
        assert!(l["onset_ms"].as_f64().unwrap().abs() <= 1.0, "{l}");
    }
    // The report is the account, and it adds up.
    let o = &report["outcomes"];
    assert_eq!(o["on_time"], 9);
    assert_eq!(o["dropped"]["monophonic"], 2);
    assert_eq!(o["dropped"]["too_fast"], 3);
    assert_eq!(report["strikes"], 9, "one valve opening a note");
    assert_eq!(
        report["restrikes_delayed"], 0,
        "a wind note waits for its fingers, not a rest"
    );
    assert!(report["fingers"].as_u64().unwrap() > 0);
    // Everything off at the end: the last write leaves the board at 0.
    assert_eq!(writes.last().unwrap()["outputs"], 0);
}

#[test]
fn the_valve_is_never_open_while_a_finger_moves_on_the_boards() {
    let dir = scratch("interlock");
    let notes: Vec<(u32, u8, u32)> = (0..40u32)
        .map(|i| (i * 130, 72 + (i * 7 % 27) as u8, 100 + (i % 3) * 15))
        .collect();
    let midi = dir.join("leaps.mid");
    std::fs::write(&midi, smf(&notes)).unwrap();
    let (report, _, writes) = play(&recorder(&dir), &midi, &dir);
    assert_eq!(report["outcomes"]["on_time"], 40, "{report}");
    let mut before = 0u64;
    for w in &writes {
        let now = w["outputs"].as_u64().unwrap();
        let (valve, fingers) = (|s: u64| s & 1 == 1, |s: u64| s & 0xFFE);
        if fingers(now) != fingers(before) {
            assert!(!valve(before), "a finger moved with the valve open: {w}");
        }
        before = now;
    }
}

#[test]
fn the_recorder_is_heard_through_its_program_at_each_notes_pitch() {
    let dir = scratch("render");
    let midi = dir.join("two.mid");
    std::fs::write(&midi, smf(&[(0, 72, 400), (500, 84, 400)])).unwrap();
    let wav = dir.join("two.wav");
    let out = orch()
        .arg("render")
        .arg(&midi)
        .arg("-o")
        .arg(&wav)
        .arg("--robot")
        .arg(recorder(&dir))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (l, r, rate) = orch_render::wav::read(&wav).unwrap();
    // The loudest stretch of each note: a zero crossing count over 100 ms gives its pitch,
    // C5 (523 Hz) then C6 (1047 Hz), within a semitone.
    let rate = rate as usize;
    let hz = |from_ms: usize| {
        let a = from_ms * rate / 1000;
        let s: Vec<f32> = (a..a + rate / 10).map(|i| l[i] + r[i]).collect();
        let ups = s.windows(2).filter(|w| w[0] < 0.0 && w[1] >= 0.0).count();
        ups as f64 * 10.0
    };
    let near = |got: f64, want: f64| (got / want).log2().abs() < 1.0 / 12.0;
    let (first, second) = (hz(250), hz(750));
    assert!(
        near(first, 523.3) && near(second, 1046.5),
        "{first} Hz, {second} Hz"
    );
}

#[test]
fn a_robot_whose_fingers_travel_longer_than_its_settle_cracks_and_the_account_says_so() {
    let dir = scratch("crack");
    // The virtual robot's fingers lift in 25 ms; a settle of 10 ms opens the valve on them.
    let text = std::fs::read_to_string(recorder(&dir)).unwrap();
    assert!(text.contains("settle = \"30ms\""));
    let robot = dir.join("hasty.toml");
    std::fs::write(
        &robot,
        text.replace("settle = \"30ms\"", "settle = \"10ms\""),
    )
    .unwrap();
    // C5 (every finger down), then E5 (6a..7b lift), then E5 again, legato: the valve
    // closes and opens again with no finger moving, so that one does not crack.
    let midi = dir.join("three.mid");
    std::fs::write(&midi, smf(&[(0, 72, 500), (500, 76, 500), (1000, 76, 400)])).unwrap();
    let (report, lines, _) = play(&robot, &midi, &dir);
    let got: Vec<(&str, Option<&str>)> = lines
        .iter()
        .map(|l| (l["outcome"].as_str().unwrap(), l["reason"].as_str()))
        .collect();
    assert_eq!(
        got,
        [
            ("dropped", Some("cracked")),
            ("dropped", Some("cracked")),
            ("on_time", None)
        ],
        "{lines:#?}"
    );
    let o = &report["outcomes"];
    assert_eq!(o["dropped"]["cracked"], 2, "{report}");
    assert_eq!(o["on_time"], 1);
    assert_eq!(report["strikes"], 1, "a cracked note is heard as no note");
    assert_eq!(report["unmatched"], 0);
    // The default settle (30 ms) plays the same notes clean.
    let (report, _, _) = play(&recorder(&dir), &midi, &dir);
    assert_eq!(report["outcomes"]["on_time"], 3, "{report}");
    assert_eq!(report["outcomes"]["dropped"]["cracked"], 0);
}

#[test]
fn on_pwm_boards_each_note_sounds_at_its_velocity_whatever_breath_it_needs() {
    let dir = scratch("breath");
    let out = orch()
        .args(["config", "--instrument", "recorder", "--boards", "pca9685"])
        .output()
        .unwrap();
    let robot = dir.join("pwm.toml");
    std::fs::write(&robot, out.stdout).unwrap();
    // C5 needs 45 % of the valve, D7 100 %: each is heard at its velocity (100).
    let midi = dir.join("low-high.mid");
    std::fs::write(&midi, smf(&[(0, 72, 400), (500, 98, 400), (1000, 84, 400)])).unwrap();
    let (report, lines, _) = play(&robot, &midi, &dir);
    assert_eq!(report["outcomes"]["on_time"], 3, "{report}");
    for l in &lines {
        let heard = l["sounded_velocity"].as_u64().unwrap();
        assert!(heard.abs_diff(100) <= 1, "{l}");
    }
}

/// The notes of `file` on channels other than 10, in the account's order (score time, then
/// the file's): (onset µs, note, the highest note held at its onset, its own included).
fn melody_of(file: &Path) -> Vec<(u64, u8, u8)> {
    let song = orch_seq::Song::parse(&std::fs::read(file).unwrap()).unwrap();
    let mut notes: Vec<(u64, u64, u8, u8)> = Vec::new(); // on, off, channel, note
    for e in song.events() {
        if let Some((ch, n, _)) = e.bytes.note_on().filter(|m| m.0 != 9) {
            notes.push((e.time_us, u64::MAX, ch, n));
        } else if let Some((ch, n)) = e.bytes.note_off().filter(|m| m.0 != 9) {
            // As MIDI has it: a Note-Off ends the note on its channel, however many times
            // it was struck (a chorale's two voices on one note end with the first).
            let open = notes
                .iter_mut()
                .filter(|x| x.1 == u64::MAX && (x.2, x.3) == (ch, n));
            open.for_each(|x| x.1 = e.time_us);
        }
    }
    let mut v: Vec<(u64, u8, u8)> = notes
        .iter()
        .map(|&(on, _, _, n)| {
            let held = notes.iter().filter(|x| x.0 <= on && x.1 > on);
            (on, n, held.map(|x| x.3).max().unwrap_or(n))
        })
        .collect();
    v.sort_by_key(|x| x.0); // stable: the file's order at the same time
    v
}

#[test]
fn the_recorder_plays_the_highest_note_of_corpus_parts_where_its_mechanics_allow() {
    let dir = scratch("corpus");
    let robot = recorder(&dir);
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/midi");
    let files = [
        "bach-bwv66-6-chorale.mid",
        "mozart-k545-exposition.mid",
        "bach-invention-01.mid",
        "m21-k525short.mid",
    ];
    let mut on_time = 0;
    for file in files {
        let path = corpus.join(file);
        let (report, lines, _) = play(&robot, &path, &dir);
        let melody = melody_of(&path);
        assert_eq!(lines.len(), melody.len(), "{file}");
        for (l, &(_, note, highest)) in lines.iter().zip(&melody) {
            assert_eq!(l["note"], note, "{file}: {l}");
            let reason = l["reason"].as_str();
            match l["outcome"].as_str().unwrap() {
                // What sounds is the part's highest note at its onset, on time.
                "on_time" => {
                    assert_eq!(note, highest, "{file}: a lower note sounded: {l}");
                    on_time += 1;
                }
                // A lower note of a chord, or under a held melody note, is not played.
                "dropped" if reason == Some("monophonic") => {
                    assert!(note < highest, "{file}: the melody was dropped: {l}")
                }
                // Where the mechanics do not allow it, the account says why: a note released
                // before its fingers settled, or one the guard cut while it prepared.
                "dropped" if matches!(reason, Some("too_fast" | "cancelled")) => {}
                "unison" | "joined" => {}
                _ => panic!("{file}: {l}"),
            }
        }
        assert_eq!(report["unmatched"], 0, "{file}");
        assert_eq!(report["outcomes"]["late"], 0, "{file}");
        assert_eq!(report["outcomes"]["early"], 0, "{file}");
    }
    assert!(on_time > 400, "{on_time} notes on time");
}
