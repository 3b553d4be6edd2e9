//! Percussion: `orch config --instrument drums` and a piano with a drum kit play every corpus
//! file with a General MIDI drum part honestly; a piano alone leaves channel 10 alone.
//!
//! What the "done when" runs: `orch config --instrument drums > kit.toml; orch play
//! --fast --robot kit.toml FILE --notes N.jsonl --writes W.jsonl`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use testkit::Scratch;

use assert_cmd::Command;
use serde_json::Value;

fn orch() -> Command {
    Command::cargo_bin("orch").unwrap()
}

fn shared_midi() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/midi")
}

fn scratch(name: &str) -> Scratch {
    Scratch::new(&format!("drums-{name}"))
}

fn json_lines(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

/// The corpus files whose manifest lists channel 10.
fn drum_files() -> Vec<String> {
    let manifest = std::fs::read_to_string(shared_midi().join("MANIFEST.tsv")).unwrap();
    let files: Vec<String> = manifest
        .lines()
        .skip(1)
        .filter(|l| {
            let cols: Vec<&str> = l.split('\t').collect();
            cols.get(10)
                .is_some_and(|c| c.split(',').any(|ch| ch.trim() == "10"))
        })
        .map(|l| l.split('\t').next().unwrap().to_string())
        .collect();
    assert!(files.len() >= 25, "{} files with drums", files.len());
    files
}

fn config(args: &[&str]) -> String {
    let out = orch().arg("config").args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}");
    String::from_utf8(out.stdout).unwrap()
}

/// The default piano with the drum kit of `orch config --instrument drums` on a fifth board.
fn piano_and_drums() -> String {
    let kit = config(&["--instrument", "drums"]);
    let start = kit.find("[[strike]]").unwrap();
    let end = kit.find("\n# The I2C bus").unwrap();
    format!(
        "{}\n[[boards]]\nkind = \"pca9555\"\naddress = 0x25\nkeys = 10\n\n{}",
        config(&[]),
        &kit[start..end]
    )
}

/// Plays `file` with `--fast --json --notes --writes` on `robot`: the report, the account and
/// the board writes.
fn play(robot: &Path, file: &str, dir: &Path) -> (Value, Vec<Value>, Vec<Value>) {
    let (notes, writes) = (dir.join("notes.jsonl"), dir.join("writes.jsonl"));
    let out = orch()
        .args(["play", "--fast", "--json", "--robot"])
        .arg(robot)
        .arg("--notes")
        .arg(&notes)
        .arg("--writes")
        .arg(&writes)
        .arg(shared_midi().join(file))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{file}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = serde_json::from_slice(&out.stdout).unwrap();
    (report, json_lines(&notes), json_lines(&writes))
}

/// The account's counts are the report's, and they add up.
fn assert_account_is_the_report(what: &str, report: &Value, lines: &[Value]) {
    let o = &report["outcomes"];
    let n = |v: &Value| v.as_u64().unwrap();
    let count = |outcome: &str, reason: Option<&str>| {
        lines
            .iter()
            .filter(|l| l["outcome"] == outcome && reason.is_none_or(|r| l["reason"] == r))
            .count() as u64
    };
    assert_eq!(lines.len() as u64, n(&report["notes"]), "{what}");
    let mut total = 0;
    for name in ["on_time", "late", "early", "unison", "joined", "skipped"] {
        assert_eq!(count(name, None), n(&o[name]), "{what}: {name}");
        total += n(&o[name]);
    }
    for (reason, k) in o["dropped"].as_object().unwrap() {
        assert_eq!(count("dropped", Some(reason)), n(k), "{what}: {reason}");
        total += n(k);
    }
    assert_eq!(
        total,
        n(&report["notes"]) + n(&report["replayed"]),
        "{what}"
    );
    assert_eq!(
        n(&report["strikes"]),
        n(&o["on_time"]) + n(&o["late"]),
        "{what}"
    );
    assert_eq!(n(&report["unmatched"]), 0, "{what}");
}

/// The kit's longest pulse by output (its bit on the kit's board): the kick's 30 ms for a
/// beater, 60 ms for the hi-hat's lift (bit 9).
fn kit_pulse_us(bit: u32) -> u64 {
    if bit == LIFT_BIT {
        60_000
    } else {
        30_000
    }
}

/// The hi-hat lift's bit on the kit's board.
const LIFT_BIT: u32 = 9;

/// Every output that went on went off again within its `max_us`, and nothing is on at the
/// end. Returns how many pulses each bit had.
fn assert_no_output_on_longer_than(
    what: &str,
    writes: &[Value],
    outputs: &[u8],
    max_us: fn(u32) -> u64,
) -> HashMap<u32, u64> {
    let mut last: HashMap<u64, u64> = HashMap::new();
    let mut since: HashMap<(u64, u32), u64> = HashMap::new();
    let mut pulses: HashMap<u32, u64> = HashMap::new();
    for w in writes {
        let (address, t) = (w["address"].as_u64().unwrap(), w["t_us"].as_u64().unwrap());
        if !outputs.contains(&(address as u8)) {
            continue;
        }
        let now = w["outputs"].as_u64().unwrap();
        let was = last.insert(address, now).unwrap_or(0);
        for bit in 0..16 {
            let (on, before) = (now >> bit & 1 == 1, was >> bit & 1 == 1);
            if on && !before {
                since.insert((address, bit), t);
            } else if !on && before {
                let t0 = since.remove(&(address, bit)).unwrap();
                assert!(
                    t - t0 <= max_us(bit),
                    "{what}: output {bit} of 0x{address:x} on {} µs > {}",
                    t - t0,
                    max_us(bit)
                );
                *pulses.entry(bit).or_default() += 1;
            }
        }
    }
    assert!(since.is_empty(), "{what}: outputs left on: {since:?}");
    pulses
}

/// What a channel-10 note may become on a robot with a kit: struck, or dropped for a reason
/// of the robot's mechanics (a beater too fast, the power budget, a drum the kit lacks).
fn assert_drum_notes_struck_or_mechanical(what: &str, lines: &[Value]) {
    for l in lines.iter().filter(|l| l["channel"] == 10) {
        let ok = match l["outcome"].as_str().unwrap() {
            "on_time" | "late" | "unison" | "joined" => true,
            "dropped" => matches!(
                l["reason"].as_str(),
                Some("too_fast" | "power" | "unmapped" | "cancelled")
            ),
            _ => false,
        };
        assert!(ok, "{what}: {l}");
    }
}

#[test]
fn the_drum_kit_plays_every_corpus_drum_part_honestly() {
    let dir = scratch("kit");
    let kit = dir.join("kit.toml");
    std::fs::write(&kit, config(&["--instrument", "drums"])).unwrap();
    let (mut struck, mut notes, mut on_time) = (0, 0, 0);
    let (mut open_hats, mut lifts) = (0, 0);
    for file in drum_files() {
        let (report, lines, writes) = play(&kit, &file, &dir);
        assert_account_is_the_report(&file, &report, &lines);
        assert_eq!(report["muted"], 0, "{file}: no beater rests on its head");
        assert_eq!(report["too_short_to_sound"], 0, "{file}: no blank");
        // The kit's board is 0x21; its loudest pulse (the kick's) is 30 ms, its lift's 60.
        let pulses = assert_no_output_on_longer_than(&file, &writes, &[0x21], kit_pulse_us);
        // Every open hi-hat struck fired its lift first (unless the lift was still up from
        // the one before: then it is skipped, and the hats are still open).
        let open = lines
            .iter()
            .filter(|l| l["channel"] == 10 && l["note"] == 46);
        let open = open.filter(|l| matches!(l["outcome"].as_str(), Some("on_time" | "late")));
        let (n, lifted) = (
            open.count() as u64,
            pulses.get(&LIFT_BIT).copied().unwrap_or(0),
        );
        assert!(
            lifted <= n && (n == 0) == (lifted == 0),
            "{file}: {n} open, {lifted} lifts"
        );
        open_hats += n;
        lifts += lifted;
        assert_drum_notes_struck_or_mechanical(&file, &lines);
        for l in &lines {
            if l["channel"] != 10 {
                assert_eq!(l["reason"], "channel", "{file}: {l}");
            }
        }
        let drums = lines.iter().filter(|l| l["channel"] == 10);
        notes += drums.clone().count();
        struck += drums
            .clone()
            .filter(|l| matches!(l["outcome"].as_str(), Some("on_time" | "late")))
            .count();
        on_time += drums.filter(|l| l["outcome"] == "on_time").count();
    }
    eprintln!("drum notes {notes}: struck {struck}, on time {on_time}; open hi-hats {open_hats}, lifts {lifts}");
    assert!(
        open_hats > 0 && lifts * 10 >= open_hats * 9,
        "{lifts} lifts for {open_hats} open hi-hats"
    );
    assert!(struck * 10 >= notes * 7, "{struck} of {notes} struck");
    assert!(
        on_time * 100 >= struck * 99,
        "{on_time} of {struck} on time"
    );
}

#[test]
fn a_piano_with_a_drum_kit_plays_both_parts_and_a_piano_alone_leaves_the_drums() {
    let dir = scratch("band");
    let band = dir.join("band.toml");
    std::fs::write(&band, piano_and_drums()).unwrap();
    let piano = dir.join("piano.toml");
    std::fs::write(&piano, config(&[])).unwrap();
    for file in drum_files().into_iter().step_by(3) {
        let (report, lines, writes) = play(&band, &file, &dir);
        let what = format!("{file} on piano + drums");
        assert_account_is_the_report(&what, &report, &lines);
        assert_drum_notes_struck_or_mechanical(&what, &lines);
        assert_no_output_on_longer_than(&what, &writes, &[0x25], kit_pulse_us);
        // The piano alone: every drum note is dropped as percussion, never played as a pitch.
        let (report, lines, _) = play(&piano, &file, &dir);
        let what = format!("{file} on the piano");
        assert_account_is_the_report(&what, &report, &lines);
        for l in lines.iter().filter(|l| l["channel"] == 10) {
            assert_eq!(l["reason"], "percussion", "{what}: {l}");
        }
        let drums = lines.iter().filter(|l| l["channel"] == 10).count() as u64;
        assert_eq!(report["outcomes"]["dropped"]["percussion"], drums, "{what}");
    }
}

#[test]
fn analyze_names_the_drum_notes_a_piano_leaves_alone_and_the_drums_a_kit_lacks() {
    let file = shared_midi().join("mma-lib-rock1.mid");
    let out = orch().arg("analyze").arg(&file).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        text.contains("are drums on channel 10") && text.contains("--instrument drums"),
        "{text}"
    );
    let dir = scratch("analyze");
    let kit = dir.join("kit.toml");
    std::fs::write(&kit, config(&["--instrument", "drums"])).unwrap();
    let out = orch()
        .args(["analyze", "--json", "--robot"])
        .arg(&kit)
        .arg(&file)
        .output()
        .unwrap();
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let wrong = report["went_wrong"].as_array().unwrap();
    // A drum the kit lacks is named as General MIDI names it, not as a pitch.
    let unmapped: Vec<&str> = wrong
        .iter()
        .filter(|w| w["outcome"] == "unmapped")
        .map(|w| w["note"].as_str().unwrap())
        .collect();
    let pitch = |n: &str| {
        let rest = n.trim_start_matches(|c: char| ('A'..='G').contains(&c));
        let rest = rest.trim_start_matches('#');
        rest.len() < n.len()
            && !rest.is_empty()
            && rest.chars().all(|c| c.is_ascii_digit() || c == '-')
    };
    assert!(
        report["outcomes"]["dropped"]["unmapped"].as_u64().unwrap() > 0,
        "the rock groove uses drums beyond the kit's"
    );
    assert!(!unmapped.is_empty());
    assert!(unmapped.iter().all(|n| !pitch(n)), "{unmapped:?}");
}

/// `orch analyze --svg` on the kit: every drum is drawn on the row of the note written (a
/// kit's output plays several notes: no dashed "fold" line to another row), and on the
/// glockenspiel a folded note's line goes to its bar's row.
#[test]
fn the_roll_draws_drums_on_their_own_rows_and_folded_bars_on_the_bars() {
    let dir = scratch("roll");
    for (instrument, file, folds) in [
        ("drums", "mma-lib-rock1.mid", false),
        ("glockenspiel", "bach-invention-01.mid", true),
    ] {
        let robot = dir.join(format!("{instrument}.toml"));
        std::fs::write(&robot, config(&["--instrument", instrument])).unwrap();
        let svg = dir.join("roll.svg");
        let out = orch()
            .args(["analyze", "--robot"])
            .arg(&robot)
            .arg("--svg")
            .arg(&svg)
            .arg(shared_midi().join(file))
            .output()
            .unwrap();
        assert!(out.status.success(), "{instrument}");
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(
            text.contains("class=\"note on_time"),
            "{instrument}: strikes drawn"
        );
        assert_eq!(text.contains("class=\"fold\""), folds, "{instrument}");
        // Struck notes are drawn as hits at their start, not as bars of their length.
        assert!(text.contains("class=\"score hit\""), "{instrument}");
        // A kit's drums on lanes named as the kit names them; bars on their pitches.
        let lanes = ["kick", "snare", "hi-hat", "crash", "ride", "not in the kit"];
        for lane in lanes {
            let named = text.contains(&format!("data-lane=\"{lane}\""));
            assert_eq!(named, !folds, "{instrument}: lane {lane}");
        }
        std::fs::copy(&svg, dir.join(format!("{instrument}.svg"))).unwrap();
    }
    eprintln!("rolls in {}", dir.display());
}

#[test]
fn every_instrument_is_printed_and_an_unknown_one_is_refused() {
    for name in ["piano", "drums", "glockenspiel"] {
        for boards in ["pca9555", "pca9685"] {
            let text = config(&["--instrument", name, "--boards", boards]);
            assert!(text.starts_with("# orch robot configuration"), "{name}");
        }
    }
    assert_eq!(config(&["--instrument", "piano"]), config(&[]));
    let out = orch()
        .args(["config", "--instrument", "tuba"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}
