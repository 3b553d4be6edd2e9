//! The `orch` command's public face: what people and scripts see.

use assert_cmd::Command;
use serde_json::Value;

fn orch() -> Command {
    Command::cargo_bin("orch").unwrap()
}

fn json_lines(stdout: &[u8]) -> Vec<Value> {
    String::from_utf8_lossy(stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect()
}

fn run(args: &[&str], stdin: impl Into<Vec<u8>>) -> (i32, Vec<u8>, String) {
    let out = orch()
        .args(args)
        .write_stdin(stdin.into())
        .output()
        .unwrap();
    (
        out.status.code().unwrap(),
        out.stdout,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn decode_json_prints_thesis_table_4_with_mido_names_and_a_summary() {
    let (code, out, _) = run(
        &["decode", "--hex", "--json", "-"],
        "90 3C 7F 40 7F 43 7F 80 40 00\n",
    );
    assert_eq!(code, 0);
    let lines = json_lines(&out);
    let expect = [
        r#"{"type":"note_on","channel":0,"note":60,"velocity":127}"#,
        r#"{"type":"note_on","channel":0,"note":64,"velocity":127}"#,
        r#"{"type":"note_on","channel":0,"note":67,"velocity":127}"#,
        r#"{"type":"note_off","channel":0,"note":64,"velocity":0}"#,
        r#"{"type":"summary","bytes":10,"messages":4,"dropped":0,"abandoned":0,"truncated":0}"#,
    ];
    assert_eq!(lines.len(), expect.len());
    for (got, want) in lines.iter().zip(expect) {
        assert_eq!(got, &serde_json::from_str::<Value>(want).unwrap());
    }
    // Key order as in the spec's example, "type" first.
    assert!(String::from_utf8_lossy(&out).starts_with(r#"{"type":"note_on","channel":0"#));
}

#[test]
fn decode_json_covers_every_message_kind() {
    let hex = "A1 3C 10 B2 40 7F C3 05 D4 20 E5 00 00 E5 7F 7F 95 3C 00 \
               F1 35 F2 01 02 F3 07 F6 F8 FA FB FC FE FF F0 7E 01 F7";
    let (code, out, _) = run(&["decode", "--hex", "--json"], hex);
    assert_eq!(code, 0);
    let lines = json_lines(&out);
    let types: Vec<&str> = lines.iter().map(|v| v["type"].as_str().unwrap()).collect();
    assert_eq!(
        types,
        [
            "polytouch",
            "control_change",
            "program_change",
            "aftertouch",
            "pitchwheel",
            "pitchwheel",
            "note_on",
            "quarter_frame",
            "songpos",
            "song_select",
            "tune_request",
            "clock",
            "start",
            "continue",
            "stop",
            "active_sensing",
            "reset",
            "sysex",
            "summary"
        ]
    );
    assert_eq!(lines[0]["channel"], 1);
    assert_eq!(lines[0]["value"], 16);
    assert_eq!(lines[1]["control"], 64);
    assert_eq!(lines[4]["pitch"], -8192);
    assert_eq!(lines[5]["pitch"], 8191);
    assert_eq!(
        lines[6]["velocity"], 0,
        "velocity-0 note-on printed as it came"
    );
    assert_eq!(
        (
            lines[7]["frame_type"].clone(),
            lines[7]["frame_value"].clone()
        ),
        (3.into(), 5.into())
    );
    assert_eq!(lines[8]["pos"], 1 + (2 << 7));
    assert_eq!(lines[17]["data"], serde_json::json!([0x7E, 0x01]));
}

#[test]
fn decode_sysex_payload_is_whole_up_to_1_mib_and_skips_realtime_bytes() {
    let mut bytes = vec![0xF0];
    bytes.extend((0..10_000u32).map(|i| (i % 128) as u8));
    bytes.insert(5000, 0xF8);
    bytes.push(0xF7);
    let (code, out, _) = run(&["decode", "--json"], bytes);
    assert_eq!(code, 0);
    let lines = json_lines(&out);
    assert_eq!(lines[0]["type"], "clock");
    let data = lines[1]["data"].as_array().unwrap();
    assert_eq!(data.len(), 10_000);
    // The clock byte sat at index 5000 of the file, between payload bytes 4998 and 4999.
    assert_eq!(data[4998], 4998 % 128);
    assert_eq!(data[4999], 4999 % 128);
}

#[test]
fn decode_text_reads_binary_from_a_file_and_ends_with_counters() {
    let dir = scratch("cli");
    let file = dir.join("in.mid.raw");
    std::fs::write(&file, [0x3C, 0x90, 0x3C, 0x7F, 0x91, 0x40]).unwrap();
    let out = orch().args(["decode"]).arg(&file).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("Note on"), "{text}");
    assert!(
        text.lines()
            .last()
            .unwrap()
            .contains("6 bytes, 1 messages, 1 dropped, 0 abandoned"),
        "{text}"
    );
}

#[test]
fn decode_counts_a_message_cut_off_by_the_end_of_input_as_truncated_not_abandoned() {
    let (code, out, _) = run(&["decode", "--hex", "--json"], "90 3C 7F 80 3C");
    assert_eq!(code, 0);
    let summary = json_lines(&out).pop().unwrap();
    assert_eq!(summary["type"], "summary");
    assert_eq!(
        (summary["truncated"].clone(), summary["abandoned"].clone()),
        (1.into(), 0.into())
    );
    // A SysEx with no end is cut off too; a whole stream is not.
    let (_, out, _) = run(&["decode", "--hex", "--json"], "F0 01 02");
    assert_eq!(json_lines(&out).pop().unwrap()["truncated"], 1);
    let (_, out, _) = run(&["decode", "--hex", "--json"], "90 3C 7F 3D 7F");
    assert_eq!(json_lines(&out).pop().unwrap()["truncated"], 0);
    let (_, out, _) = run(&["decode", "--hex"], "90 3C 7F 80");
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.trim_end()
            .ends_with("4 bytes, 1 messages, 0 dropped, 0 abandoned, 1 truncated"),
        "{text}"
    );
}

#[test]
fn decode_shows_the_start_and_length_of_a_sysex_longer_than_it_keeps() {
    let shown = orch_stage::messages::SYSEX_SHOWN;
    let mut bytes = vec![0xF0];
    bytes.extend((0..shown + 1000).map(|i| (i % 128) as u8));
    bytes.push(0xF7);
    let (code, out, _) = run(&["decode", "--json"], bytes.clone());
    assert_eq!(code, 0);
    let lines = json_lines(&out);
    assert_eq!(lines[0]["type"], "sysex");
    assert_eq!(lines[0]["data"].as_array().unwrap().len(), shown);
    assert_eq!(lines[0]["length"], shown + 1000);
    let (code, out, _) = run(&["decode"], bytes);
    assert_eq!(code, 0);
    let text = String::from_utf8(out).unwrap();
    let first = text.lines().next().unwrap();
    assert!(
        first.ends_with(&format!(
            " ... (1000 more not shown) F7  [{} data bytes]",
            shown + 1000
        )),
        "{}",
        &first[first.len() - 80..]
    );
}

#[test]
fn bad_hex_and_missing_files_exit_2_with_a_clear_message() {
    let (code, _, err) = run(&["decode", "--hex"], "90 3C\n9G");
    assert_eq!(code, 2);
    assert!(err.contains("line 2"), "{err}");
    let (code, _, err) = run(&["interpret", "/no/such/file"], "");
    assert_eq!(code, 2);
    assert!(err.contains("/no/such/file"), "{err}");
    let (code, _, _) = run(&["decode", "--no-such-flag"], "");
    assert_eq!(code, 2);
}

#[test]
fn interpret_json_writes_one_board_per_change_and_ends_with_final_state() {
    // Table 3, then a Note-Off for 64 and a note below the keyboard (24 folds to 36).
    let hex = "90 3C 7F 90 40 7F 90 43 7F 80 40 00 90 18 7F";
    let (code, out, _) = run(&["interpret", "--hex", "--json"], hex);
    assert_eq!(code, 0);
    let lines = json_lines(&out);
    let want = [
        r#"{"t_us":640,"byte":2,"address":34,"outputs":256}"#,
        r#"{"t_us":1600,"byte":5,"address":34,"outputs":4352}"#,
        r#"{"t_us":2560,"byte":8,"address":34,"outputs":37120}"#,
        r#"{"t_us":3520,"byte":11,"address":34,"outputs":33024}"#,
        r#"{"t_us":4480,"byte":14,"address":33,"outputs":1}"#,
        r#"{"type":"final","boards":[{"address":33,"outputs":1},{"address":34,"outputs":33024},{"address":35,"outputs":0},{"address":36,"outputs":0}]}"#,
    ];
    assert_eq!(lines.len(), want.len(), "{}", String::from_utf8_lossy(&out));
    for (got, want) in lines.iter().zip(want) {
        assert_eq!(got, &serde_json::from_str::<Value>(want).unwrap());
    }
}

#[test]
fn interpret_guard_delays_a_repeated_note_and_guard_off_does_not() {
    // On, off, and on again 36 ms later: the guard makes the key rest its 60 ms first (a wait
    // of 24 ms, within the 30 ms late limit). Active-sensing bytes fill the time.
    let hex = "90 3C 7F 80 3C 00 90 3C 7F";
    let mut long = String::from("90 3C 7F 80 3C 00");
    for _ in 0..110 {
        long.push_str(" FE");
    }
    long.push_str(" 90 3C 7F");
    for _ in 0..200 {
        long.push_str(" FE");
    }
    let (_, out, _) = run(&["interpret", "--hex", "--json"], long.clone());
    let lines = json_lines(&out);
    let strike = lines
        .iter()
        .find(|l| l["byte"].is_null() && l["outputs"] == 256)
        .expect("a timer strike");
    assert_eq!(
        strike["t_us"],
        1600 + 60_000,
        "rests the whole gap after its release"
    );

    let (_, out, _) = run(&["interpret", "--hex", "--json", "--guard", "off"], hex);
    let lines = json_lines(&out);
    assert_eq!(lines[2]["byte"], 8);
    assert_eq!(lines[2]["outputs"], 256);
}

#[test]
fn interpret_guard_on_wins_over_a_robot_file_that_disables_it_and_says_so() {
    let dir = scratch("guard");
    let off = dir.join("guard-off.toml");
    std::fs::write(&off, "[guard]\nenabled = false\n").unwrap();
    let off = off.to_str().unwrap();
    // On, off, on again at once: only the guard delays the re-strike.
    let hex = "90 3C 7F 80 3C 00 90 3C 7F";
    let restruck_by_byte_8 = |out: &[u8]| {
        json_lines(out)
            .iter()
            .any(|l| l["byte"] == 8 && l["outputs"] == 256)
    };
    // The file alone: no guard, the note re-strikes at byte 8, and nothing is said.
    let (code, out, err) = run(&["interpret", "--hex", "--json", "--robot", off], hex);
    assert_eq!(code, 0);
    assert!(restruck_by_byte_8(&out));
    assert!(err.is_empty(), "{err}");
    // --guard on wins: the re-strike waits, and stderr says so loudly.
    let (code, out, err) = run(
        &[
            "interpret",
            "--hex",
            "--json",
            "--robot",
            off,
            "--guard",
            "on",
        ],
        hex,
    );
    assert_eq!(code, 0);
    assert!(!restruck_by_byte_8(&out), "the guard must be on");
    assert!(
        err.contains("WARNING") && err.contains("--guard on") && err.contains("guard-off.toml"),
        "{err}"
    );
    assert!(err.contains("safety guard is ON"), "{err}");
    // --guard off over a file that has it on says so too; agreeing flags say nothing.
    let on = dir.join("guard-on.toml");
    std::fs::write(&on, "[guard]\nenabled = true\n").unwrap();
    let on = on.to_str().unwrap();
    let (_, out, err) = run(
        &[
            "interpret",
            "--hex",
            "--json",
            "--robot",
            on,
            "--guard",
            "off",
        ],
        hex,
    );
    assert!(restruck_by_byte_8(&out));
    assert!(err.contains("safety guard is OFF"), "{err}");
    let (_, _, err) = run(
        &[
            "interpret",
            "--hex",
            "--json",
            "--robot",
            on,
            "--guard",
            "on",
        ],
        hex,
    );
    assert!(err.is_empty(), "{err}");
}

#[test]
fn interpret_text_shows_fingers_and_stats() {
    let (code, out, _) = run(&["interpret", "--hex"], "90 3C 7F");
    assert_eq!(code, 0);
    let text = String::from_utf8_lossy(&out);
    assert!(
        text.contains("0x22 <- 0x0100  |........#.......|"),
        "{text}"
    );
    assert!(text.contains("1 notes: 1 sounded"), "{text}");
    assert!(text.contains("# final: 0x21=0x0000 0x22=0x0100"), "{text}");
    assert!(text.contains("0 abandoned, 0 truncated"), "{text}");
}

#[test]
fn interpret_says_when_the_end_of_the_input_cut_a_message_off() {
    let (code, out, _) = run(&["interpret", "--hex"], "90 3C 7F 40");
    assert_eq!(code, 0);
    let text = String::from_utf8_lossy(&out);
    assert!(text.contains("0 abandoned, 1 truncated"), "{text}");
}

#[test]
fn robot_file_changes_the_mapping_and_a_bad_one_names_the_field() {
    let dir = scratch("robot");
    let good = dir.join("robot.toml");
    std::fs::write(
        &good,
        "[keys]\nlow = 60\nhigh = 71\nout_of_range = \"drop\"\nchannels = [2]\n\n[[boards]]\naddress = 0x20\nkeys = 12\nfirst_bit = 4\n",
    )
    .unwrap();
    let out = orch()
        .args(["interpret", "--hex", "--json", "--robot"])
        .arg(&good)
        .write_stdin("91 3D 7F 90 3D 7F 91 48 7F")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = json_lines(&out.stdout);
    assert_eq!(lines.len(), 2, "only channel 2's in-range note plays");
    assert_eq!(lines[0]["address"], 0x20);
    assert_eq!(lines[0]["outputs"], 1 << 5);

    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[guard]\nrestrike_gap = \"soon\"\n").unwrap();
    let out = orch()
        .args(["interpret", "--robot"])
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("guard.restrike_gap") && err.contains("bad.toml"),
        "{err}"
    );
}

#[test]
fn config_prints_a_commented_default_that_reads_back() {
    let out = orch().arg("config").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("# orch robot configuration"));
    let dir = scratch("config");
    let file = dir.join("robot.toml");
    std::fs::write(&file, text.as_bytes()).unwrap();
    let out = orch()
        .args(["interpret", "--hex", "--json", "--robot"])
        .arg(&file)
        .write_stdin("90 60 7F")
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(json_lines(&out.stdout)[0]["address"], 0x24);
}

#[test]
fn config_for_pca9685_boards_reads_back_and_interpret_writes_their_duties() {
    let out = orch()
        .args(["config", "--boards", "pca9685"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    let dir = scratch("config-pwm");
    let file = dir.join("robot.toml");
    std::fs::write(&file, text.as_bytes()).unwrap();
    // Middle C at 127, D at 1, C released: one write of duties to the one board each time.
    let out = orch()
        .args(["interpret", "--hex", "--json", "--robot"])
        .arg(&file)
        .write_stdin("90 3C 7F 3E 01 80 3C 00")
        .output()
        .unwrap();
    assert!(out.status.success());
    let lines = json_lines(&out.stdout);
    let duty = |i: usize| -> Vec<u64> {
        lines[i]["duty"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect()
    };
    // Key 24 (board 1 at 0x41, output 8) and key 26 (output 10).
    assert_eq!(lines[0]["address"], 0x41);
    assert_eq!(duty(0)[8], 4095, "velocity 127: the loudest, 100 %");
    assert_eq!(duty(1)[10], 1843, "velocity 1: the softest, 45 %");
    assert_eq!(duty(2)[8], 0);
    assert_eq!(duty(2)[10], 1843);
    assert_eq!(lines[3]["type"], "final");
    // The virtual robot plays it: every note at its velocity, on time.
    let out = orch()
        .args(["play", "--fast", "--json", "--robot"])
        .arg(&file)
        .arg("examples/ode-to-joy.mid")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["outcomes"]["on_time"], report["notes"]);
    assert_eq!(report["outcomes"]["dropped"]["too_soft"], 0);
    assert_eq!(report["velocity_error"]["max"], 0);
    // --writes gives a PCA9685's writes as its 16 duties after each.
    let writes = dir.join("writes.jsonl");
    let out = orch()
        .args(["play", "--fast", "--writes"])
        .arg(&writes)
        .arg("--robot")
        .arg(&file)
        .arg("examples/ode-to-joy.mid")
        .output()
        .unwrap();
    assert!(out.status.success());
    let lines = json_lines(&std::fs::read(&writes).unwrap());
    let pwm: Vec<_> = lines
        .iter()
        .filter(|l| l["address"].as_u64() >= Some(0x40))
        .collect();
    assert!(!pwm.is_empty());
    for l in &pwm {
        let duty = l["duty"]
            .as_array()
            .expect("a PCA9685 write has its duties");
        assert_eq!(duty.len(), 16);
        assert!(l.get("outputs").is_none(), "{l}");
    }
    // Among them, holds at 35 % (1433).
    assert!(pwm
        .iter()
        .any(|l| l["duty"].as_array().unwrap().iter().any(|d| d == 1433)));
    // And the on/off default is unchanged by the flag's default.
    let plain = orch().arg("config").output().unwrap();
    let named = orch()
        .args(["config", "--boards", "pca9555"])
        .output()
        .unwrap();
    assert_eq!(plain.stdout, named.stdout);
}

/// `--notes`: one line for every note of the file, in score order, whose counts are the
/// report's, on the thesis's robot and on PCA9685 boards, for play and for analyze.
#[test]
fn the_note_by_note_account_has_every_note_in_score_order_and_the_reports_counts() {
    let dir = scratch("notes");
    let pwm = dir.join("pwm.toml");
    let out = orch()
        .args(["config", "--boards", "pca9685"])
        .output()
        .unwrap();
    std::fs::write(&pwm, &out.stdout).unwrap();
    for file in ["beethoven-op18no1-mvt1.mid", "bach-bwv66-6-chorale.mid"] {
        for robot in [None, Some(&pwm)] {
            for command in ["play", "analyze"] {
                let notes = dir.join("notes.jsonl");
                let mut cmd = orch();
                cmd.arg(command);
                if command == "play" {
                    cmd.arg("--fast");
                }
                if let Some(r) = robot {
                    cmd.arg("--robot").arg(r);
                }
                let out = cmd
                    .arg("--json")
                    .arg("--notes")
                    .arg(&notes)
                    .arg(corpus(file))
                    .output()
                    .unwrap();
                let what = format!("{command} {file} on {robot:?}");
                assert!(out.status.success(), "{what}");
                let report: Value = serde_json::from_slice(&out.stdout).unwrap();
                let lines = json_lines(&std::fs::read(&notes).unwrap());
                assert_eq!(
                    lines.len() as u64,
                    report["notes"].as_u64().unwrap(),
                    "{what}"
                );
                let count = |outcome: &str, reason: Option<&str>| {
                    lines
                        .iter()
                        .filter(|l| {
                            l["outcome"] == outcome && reason.is_none_or(|r| l["reason"] == r)
                        })
                        .count() as u64
                };
                let o = &report["outcomes"];
                for name in ["on_time", "late", "early", "unison", "joined", "skipped"] {
                    assert_eq!(
                        count(name, None),
                        o[name].as_u64().unwrap(),
                        "{what}: {name}"
                    );
                }
                for (reason, n) in o["dropped"].as_object().unwrap() {
                    assert_eq!(
                        count("dropped", Some(reason)),
                        n.as_u64().unwrap(),
                        "{what}: {reason}"
                    );
                }
                assert_eq!(
                    count("unmatched", None),
                    report["unmatched"].as_u64().unwrap()
                );
                let mut last = f64::MIN;
                for l in &lines {
                    let t = l["t_ms"].as_f64().unwrap();
                    assert!(t >= last, "{what}: score order");
                    last = t;
                    assert!(l["bar"].as_u64().unwrap() >= 1 && l["beat"].as_u64().unwrap() >= 1);
                    assert!((1..=16).contains(&l["channel"].as_u64().unwrap()));
                    let struck =
                        matches!(l["outcome"].as_str(), Some("on_time" | "late" | "early"));
                    assert_eq!(l["sounded_ms"].is_null(), !struck, "{what}: {l}");
                    assert_eq!(
                        l["reason"].is_null(),
                        l["outcome"] != "dropped",
                        "{what}: {l}"
                    );
                    if struck {
                        let (h, e) = (
                            l["sounded_ms"].as_f64().unwrap(),
                            l["onset_ms"].as_f64().unwrap(),
                        );
                        assert!((h - t - e).abs() < 0.002, "{what}: {l}");
                        assert!(l["sent_ms"].as_f64().unwrap() < h, "{what}: {l}");
                    }
                }
            }
        }
    }
}

/// `orch analyze --svg`: a piano roll with one note element for every note, by outcome as
/// the report counts them, a dropped note's reason on it; an unwritable path exits 2.
#[test]
fn analyze_svg_draws_every_note_with_the_reports_outcomes() {
    let dir = scratch("svg");
    let pwm = dir.join("pwm.toml");
    let out = orch()
        .args(["config", "--boards", "pca9685"])
        .output()
        .unwrap();
    std::fs::write(&pwm, &out.stdout).unwrap();
    for (file, robot) in [
        ("mma-aria-girl.mid", None),
        ("bach-bwv66-6-chorale.mid", Some(&pwm)),
    ] {
        let svg = dir.join("roll.svg");
        let mut cmd = orch();
        cmd.arg("analyze");
        if let Some(r) = robot {
            cmd.arg("--robot").arg(r);
        }
        let out = cmd
            .arg("--json")
            .arg("--svg")
            .arg(&svg)
            .arg(corpus(file))
            .output()
            .unwrap();
        assert!(out.status.success(), "{file}");
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<?xml"), "{file}");
        assert!(text.trim_end().ends_with("</svg>"), "{file}");
        let notes: Vec<&str> = text
            .lines()
            .filter(|l| l.starts_with("<g class=\"note "))
            .collect();
        assert_eq!(
            notes.len() as u64,
            report["notes"].as_u64().unwrap(),
            "{file}"
        );
        let count = |attr: &str| notes.iter().filter(|l| l.contains(attr)).count() as u64;
        let o = &report["outcomes"];
        for name in ["on_time", "late", "early", "unison", "joined", "skipped"] {
            assert_eq!(
                count(&format!("data-outcome=\"{name}\"")),
                o[name].as_u64().unwrap(),
                "{file}: {name}"
            );
        }
        for (reason, n) in o["dropped"].as_object().unwrap() {
            assert_eq!(
                count(&format!("data-reason=\"{reason}\"")),
                n.as_u64().unwrap(),
                "{file}: {reason}"
            );
        }
        assert_eq!(
            text.contains("fill opacity: loudness"),
            robot.is_some(),
            "{file}: loudness drawn only on PWM boards"
        );
    }
    let out = orch()
        .args(["analyze", "--svg", "/nonexistent-dir/roll.svg"])
        .arg(corpus("bach-bwv66-6-chorale.mid"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--svg"));
}

/// A folder of the test's own for files it writes, removed when the test ends.
fn scratch(tag: &str) -> testkit::Scratch {
    testkit::Scratch::new(tag)
}

fn corpus(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/midi")
        .join(name)
}

#[test]
fn play_and_analyze_refuse_malformed_files_with_exit_2_and_no_panic() {
    let dir = scratch("bad");
    let good = std::fs::read(corpus("bach-invention-01.mid")).unwrap();
    let mut files: Vec<std::path::PathBuf> = [
        "bad-empty.mid",
        "bad-header-magic.mid",
        "bad-no-running-status.mid",
        "bad-track-length.mid",
        "bad-truncated-half.mid",
    ]
    .iter()
    .map(|n| corpus(n))
    .collect();
    let made: [(&str, Vec<u8>); 4] = [
        ("truncated-header.mid", good[..10].to_vec()),
        ("truncated-track.mid", good[..good.len() / 3].to_vec()),
        (
            "random.mid",
            (0..4000u32)
                .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
                .collect(),
        ),
        ("header-only.mid", good[..14].to_vec()),
    ];
    for (name, bytes) in made {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        files.push(p);
    }
    files.push(dir.join("does-not-exist.mid"));
    for file in files {
        for cmd in [&["play", "--fast"][..], &["analyze"][..]] {
            let out = orch().args(cmd).arg(&file).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(
                out.status.code(),
                Some(2),
                "{cmd:?} {}: {err}",
                file.display()
            );
            assert!(
                err.contains("orch: error:") && !err.contains("panicked"),
                "{err}"
            );
        }
    }
}

#[test]
fn play_fast_json_report_adds_up() {
    let out = orch()
        .args(["play", "--fast", "--json"])
        .arg(corpus("joplin-maple-leaf-rag.mid"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: Value = serde_json::from_slice(&out.stdout).unwrap();
    let o = &r["outcomes"];
    let d = &o["dropped"];
    let n = |v: &Value| v.as_u64().unwrap();
    let dropped: u64 = [
        "channel",
        "range",
        "power",
        "too_fast",
        "cancelled",
        "stopped",
    ]
    .iter()
    .map(|k| n(&d[*k]))
    .sum();
    let sum = ["on_time", "late", "unison", "joined"]
        .iter()
        .map(|k| n(&o[*k]))
        .sum::<u64>()
        + dropped;
    assert_eq!(r["notes"], 2308);
    assert_eq!(sum, 2308, "{o}");
    assert_eq!(n(&r["strikes"]), n(&o["on_time"]) + n(&o["late"]));
    assert_eq!(r["unmatched"], 0);
    assert_eq!(r["folded"], 9);
    for f in ["median", "p99", "max"] {
        assert!(r["onset_ms"][f].is_number(), "onset_ms.{f}");
    }
    // The comparison without compensation is analyze's (a play renders once).
    assert!(r["onset_uncompensated_ms"].is_null());
    let out = orch()
        .args(["analyze", "--json"])
        .arg(corpus("joplin-maple-leaf-rag.mid"))
        .output()
        .unwrap();
    let a: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(a["onset_uncompensated_ms"]["median"].as_f64().unwrap() >= 15.0);
    assert_eq!(a["outcomes"], r["outcomes"]);
    assert!(r["onset_ms"]["max"].as_f64().unwrap() < 1.0);
    assert!(r["peak_keys_down"].as_u64().unwrap() >= 4);
}

#[test]
fn play_writes_lists_every_board_write_of_the_performance() {
    let path = testkit::in_test("writes.jsonl");
    let play = |writes: Option<&std::path::Path>| {
        let mut cmd = orch();
        cmd.args(["play", "--fast", "--json"])
            .arg(corpus("m21-k525short.mid"));
        if let Some(w) = writes {
            cmd.arg("--writes").arg(w);
        }
        let out = cmd.output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<Value>(&out.stdout).unwrap()
    };
    let with = play(Some(&path));
    // Keeping every write for the file changes nothing of the performance.
    assert_eq!(with, play(None));
    let lines = json_lines(&std::fs::read(&path).unwrap());
    assert_eq!(lines.len() as u64, with["bus"]["writes"].as_u64().unwrap());
    let mut outputs = [0u16; 4];
    let (mut presses, mut last_t) = (0u64, 0u64);
    for l in &lines {
        assert_eq!(l["out"], "sim");
        let t = l["t_us"].as_u64().unwrap();
        assert!(t >= last_t, "writes in time order");
        last_t = t;
        let board = (l["address"].as_u64().unwrap() - 0x21) as usize;
        let now = l["outputs"].as_u64().unwrap() as u16;
        presses += u64::from((now & !outputs[board]).count_ones());
        outputs[board] = now;
    }
    // Every strike is a press on a board; a press may also fail to sound.
    let strikes = with["strikes"].as_u64().unwrap();
    assert!(
        presses >= strikes && strikes > 150,
        "{presses} presses, {strikes} strikes"
    );
    assert_eq!(outputs, [0; 4], "every key up at the end");
    // A file that cannot be written is bad input, before anything plays.
    let out = orch()
        .args(["play", "--fast", "--writes", "/nonexistent/dir/w.jsonl"])
        .arg(corpus("m21-k525short.mid"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--writes /nonexistent/dir/w.jsonl"));
    std::fs::remove_file(&path).ok();
}

#[test]
fn play_from_a_bar_starts_there_and_counts_the_notes_before_it_skipped() {
    let file = corpus("joplin-maple-leaf-rag.mid");
    let song = orch_seq::Song::parse(&std::fs::read(&file).unwrap()).unwrap();
    let from = song.bar_start_us(9).unwrap();
    assert_eq!(song.bar_beat(from), (9, 1));
    let before = song
        .events()
        .iter()
        .filter(|e| e.time_us < from && e.bytes.note_on().is_some())
        .count() as u64;
    assert!(before > 100);
    let out = orch()
        .args(["play", "--fast", "--json", "--from", "9"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let r: Value = serde_json::from_slice(&out.stdout).unwrap();
    let o = &r["outcomes"];
    let n = |v: &Value| v.as_u64().unwrap();
    assert_eq!(n(&o["skipped"]), before, "{r}");
    assert_eq!((n(&r["jumps"]), n(&r["replayed"])), (1, 0));
    let dropped: u64 = o["dropped"].as_object().unwrap().values().map(n).sum();
    let played: u64 = ["on_time", "late", "early", "unison", "joined"]
        .iter()
        .map(|k| n(&o[*k]))
        .sum();
    assert_eq!(played + dropped + before, 2308, "{r}");
    assert_eq!(dropped, 0, "{r}");
    for bad in ["0", "100000"] {
        let out = orch()
            .args(["play", "--fast", "--from", bad])
            .arg(&file)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad}: {out:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--from"));
    }
}

#[test]
fn analyze_says_what_will_go_wrong() {
    let out = orch()
        .arg("analyze")
        .arg(corpus("fof-feelings.mid"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("notes are outside the keys and will be folded"),
        "{text}"
    );
    let robot = testkit::in_test("drop.toml");
    std::fs::write(&robot, "[keys]\nout_of_range = \"drop\"\n").unwrap();
    let out = orch()
        .args(["analyze", "--json", "--robot"])
        .arg(&robot)
        .arg(corpus("fof-feelings.mid"))
        .output()
        .unwrap();
    let r: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        r["outcomes"]["dropped"]["range"], 491,
        "the MANIFEST's out-of-range count"
    );
    // And it lists the notes that go wrong, worst first, with bar:beat and names.
    let wrong = r["went_wrong"].as_array().unwrap();
    assert!(wrong.iter().filter(|w| w["outcome"] == "range").count() == 491);
    assert!(wrong[0]["bar"].as_u64().unwrap() >= 1);
    assert!(wrong[0]["note"].is_string());
}

#[test]
fn play_tempo_and_no_compensation_flags_change_the_performance() {
    let report = |extra: &[&str]| -> Value {
        let out = orch()
            .args(["play", "--fast", "--json"])
            .args(extra)
            .arg(corpus("m21-test06.mid"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let normal = report(&[]);
    let fast = report(&["--tempo", "2"]);
    let late = report(&["--no-compensation"]);
    let secs = |v: &Value| v["seconds"].as_f64().unwrap();
    assert!(
        (secs(&fast) - secs(&normal) / 2.0).abs() < 0.5,
        "{} vs {}",
        secs(&fast),
        secs(&normal)
    );
    assert!(normal["onset_ms"]["median"].as_f64().unwrap() < 1.0);
    assert!(
        late["onset_ms"]["median"].as_f64().unwrap() >= 15.0,
        "{late}"
    );
    let file = corpus("m21-test06.mid");
    let (code, _, err) = run(
        &["play", "--fast", "--tempo", "0", file.to_str().unwrap()],
        "",
    );
    assert_eq!(code, 2, "{err}");
}

#[test]
fn decode_shows_each_message_as_it_arrives_on_a_live_stream() {
    use std::io::{BufRead, BufReader, Write as _};
    use std::process::{Command as Std, Stdio};
    let mut child = Std::new(env!("CARGO_BIN_EXE_orch"))
        .args(["decode", "--hex", "--json", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    // Should the output wait for the end of the input, the read below would block: end it.
    let pid = child.id().to_string();
    std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_secs(20));
        let _ = Std::new("kill").arg(&pid).status();
    });
    let mut stdin = child.stdin.take().unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    // The line comes out while the input is still open, as from a MIDI port.
    writeln!(stdin, "90 3C 7F").unwrap();
    stdin.flush().unwrap();
    let first: Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    assert_eq!(first["type"], "note_on");
    writeln!(stdin, "80 3C 00").unwrap();
    drop(stdin);
    let rest: Vec<String> = lines.map(|l| l.unwrap()).collect();
    assert_eq!(rest.len(), 2, "{rest:?}");
    assert!(child.wait().unwrap().success());
}
