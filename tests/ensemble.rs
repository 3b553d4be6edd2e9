//! An ensemble on one host: a robot.toml with the piano, the drum kit and the recorder of
//! `orch config --instrument …`, each on its channels, plays a corpus file with those parts as
//! one robot; the report says how each group fared, and the groups add up to the whole.

use std::path::{Path, PathBuf};
use std::process::Command;
use testkit::Scratch;

use serde_json::Value;

#[path = "support/serve.rs"]
mod serve;

fn orch() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orch"))
}

fn config(args: &[&str]) -> String {
    let out = orch().arg("config").args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}");
    String::from_utf8(out.stdout).unwrap()
}

/// From `[[strike]]` or `[[fingered]]` to the bus section: the group's tables.
fn group_of(text: &str, table: &str) -> String {
    let start = text.find(table).unwrap();
    let end = text[start..]
        .find("\n# The I2C bus")
        .map_or(text.len(), |e| start + e);
    text[start..end].to_string()
}

/// The default piano on `piano` channels, the kit on a fifth board (0x25), the recorder on a
/// sixth (0x26) playing channel `recorder`.
pub fn ensemble(piano: &str, recorder: u8) -> String {
    let kit = group_of(&config(&["--instrument", "drums"]), "[[strike]]");
    let wind = group_of(&config(&["--instrument", "recorder"]), "[[fingered]]").replace(
        "channels = \"melodic\"",
        &format!("channels = [{recorder}]"),
    );
    let board = |address: u8, keys: u8| {
        format!("[[boards]]\nkind = \"pca9555\"\naddress = {address:#04x}\nkeys = {keys}\nfirst_bit = 0\n\n")
    };
    let piano_toml = config(&[]).replace("channels = \"melodic\"", &format!("channels = {piano}"));
    format!(
        "{piano_toml}\n{}{}{kit}\n{wind}\n",
        board(0x25, 10),
        board(0x26, 12)
    )
}

fn scratch(name: &str) -> Scratch {
    Scratch::new(&format!("ensemble-{name}"))
}

/// The corpus file: channel 9 a bass line and 16 chords (the piano), 10 drums, 15 a melody
/// (the recorder, its notes below C5 folded up an octave).
const FILE: &str = "mma-harmony-smile.mid";

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/midi")
        .join(name)
}

#[test]
fn piano_drums_and_recorder_play_a_corpus_file_as_one_robot_and_each_group_is_reported() {
    let dir = scratch("play");
    let robot = dir.join("ensemble.toml");
    std::fs::write(&robot, ensemble("[9, 16]", 15)).unwrap();
    let notes = dir.join("notes.jsonl");
    let out = orch()
        .args(["play", "--fast", "--json", "--robot"])
        .arg(&robot)
        .arg("--notes")
        .arg(&notes)
        .arg(corpus(FILE))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let n = |v: &Value| v.as_u64().unwrap();
    let groups = report["groups"].as_array().expect("per-group figures");
    let names: Vec<&str> = groups.iter().map(|g| g["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["keyboard", "drums", "recorder"], "{report}");
    // Each group played its own part: its notes struck, on time.
    for g in groups {
        let o = &g["outcomes"];
        assert!(n(&o["on_time"]) >= 10, "{g}");
        assert_eq!(n(&o["late"]) + n(&o["early"]), 0, "{g}");
    }
    // The groups add up to the whole: every note of the file is one group's, or no group's
    // (a channel none listens to).
    let lines: Vec<Value> = std::fs::read_to_string(&notes)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let grouped: u64 = groups.iter().map(|g| n(&g["notes"])).sum();
    let unheard = lines.iter().filter(|l| l["key"].is_null()).count() as u64;
    assert_eq!(grouped + unheard, n(&report["notes"]), "{report}");
    for name in ["on_time", "late", "early", "unison", "joined"] {
        let sum: u64 = groups.iter().map(|g| n(&g["outcomes"][name])).sum();
        assert_eq!(sum, n(&report["outcomes"][name]), "{name}");
    }
    // The text report has a line for each group.
    let out = orch()
        .args(["play", "--fast", "--robot"])
        .arg(&robot)
        .arg(corpus(FILE))
        .output()
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    for name in ["keyboard", "drums", "recorder"] {
        assert!(
            text.lines()
                .any(|l| l.starts_with("group") && l.contains(name)),
            "{text}"
        );
    }
}

/// `orch serve` plays the same robot: the report at the end says how each group fared.
#[test]
fn orch_serve_plays_the_ensemble_and_reports_each_group() {
    let dir = scratch("serve");
    let robot = dir.join("ensemble.toml");
    std::fs::write(&robot, ensemble("[9, 16]", 15)).unwrap();
    let s = serve::Served::start(&[
        "--listen",
        "127.0.0.1:0",
        "--robot",
        robot.to_str().unwrap(),
    ]);
    let bytes = std::fs::read(corpus(FILE)).unwrap();
    let octets = ["Content-Type: application/octet-stream"];
    let (status, body) = s.request("POST", "/api/songs?name=smile.mid", &octets, &bytes);
    assert_eq!(status, 200, "{body}");
    let id = serde_json::from_str::<Value>(&body).unwrap()["id"].clone();
    let (status, body) = s.command(r#"{"cmd":"tempo","factor":20}"#);
    assert_eq!(status, 200, "{body}");
    let (status, body) = s.command(&format!(r#"{{"cmd":"play","song":{id}}}"#));
    assert_eq!(status, 200, "{body}");
    s.wait_state(60, |st| st["ended"]["name"] == "smile.mid");
    let ended = s.get_json("/api/ended");
    let groups = ended["report"]["groups"]
        .as_array()
        .expect("per-group figures");
    let names: Vec<&str> = groups.iter().map(|g| g["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["keyboard", "drums", "recorder"], "{ended}");
    for name in ["keyboard", "drums", "recorder"] {
        let text = ended["text"].as_str().unwrap();
        assert!(
            text.lines()
                .any(|l| l.starts_with("group") && l.contains(name)),
            "{text}"
        );
    }
}
