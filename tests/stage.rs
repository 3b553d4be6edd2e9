//! The same performance through the `orch-stage` library as through `orch play` and
//! `orch analyze`: what a second front end (a web page, a daemon) gets from the library — the
//! report as JSON and as text, the note-by-note account, the analysis — is what the command
//! prints, byte for byte.
//!
//! The library is driven the way such a front end would drive it: load the song and the robot,
//! set up, open the outputs, play (on the virtual clock, so both sides are deterministic), and
//! ask for the reports and the account.

use std::path::{Path, PathBuf};
use testkit::Scratch;

use assert_cmd::Command;
use orch_io::OutSpec;
use orch_stage::{account, analyze, bars, load_robot, load_song, session, setup, text, Reports};

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/midi")
        .join(name)
}

/// A folder of the test's own for files it writes.
fn scratch(tag: &str) -> Scratch {
    Scratch::new(&format!("stage-{tag}"))
}

/// `orch ARGS`: its standard output, and the file `--notes` wrote (if `notes` is given).
fn orch(args: &[&str], notes: Option<&Path>) -> (String, String) {
    let mut cmd = Command::cargo_bin("orch").unwrap();
    cmd.args(args);
    if let Some(n) = notes {
        cmd.arg("--notes").arg(n);
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "orch {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let notes = notes.map_or(String::new(), |n| std::fs::read_to_string(n).unwrap());
    (String::from_utf8(out.stdout).unwrap(), notes)
}

/// One way to play a file: the robot file (none: the thesis's), the tempo factor, the bar to
/// start at, the outputs (`--out`; none: the virtual robot alone).
struct Play<'a> {
    file: PathBuf,
    robot: Option<&'a Path>,
    tempo: f64,
    from: Option<u32>,
    outs: &'a [&'a str],
}

impl Play<'_> {
    /// The command line of `orch play --fast` for it.
    fn args(&self) -> Vec<String> {
        let mut a = vec![
            "play".into(),
            self.file.display().to_string(),
            "--fast".into(),
        ];
        a.extend(["--tempo".into(), self.tempo.to_string()]);
        if let Some(r) = self.robot {
            a.extend(["--robot".into(), r.display().to_string()]);
        }
        if let Some(bar) = self.from {
            a.extend(["--from".into(), bar.to_string()]);
        }
        for o in self.outs {
            a.extend(["--out".into(), o.to_string()]);
        }
        a
    }

    /// Through the library: every robot's end of the session, and the song (for the account).
    fn through_stage(&self) -> (Vec<session::Ended>, orch_seq::Song, orch_perform::Tempo) {
        let song = load_song(&self.file).unwrap();
        let robot = load_robot(self.robot).unwrap();
        let tempo = setup::tempo(self.tempo).unwrap();
        let setup = setup::setup(&robot, true, tempo);
        let from_us = self.from.map(|bar| bars::start_of(&song, bar).unwrap());
        let specs = if self.outs.is_empty() {
            vec![OutSpec::parse("sim").unwrap()]
        } else {
            self.outs
                .iter()
                .map(|o| OutSpec::parse(o).unwrap())
                .collect()
        };
        let lanes = session::open_lanes(specs, &setup).unwrap();
        let ended = setup::play_lanes_fast(&song, lanes, from_us).unwrap();
        (ended, song, tempo)
    }

    /// Plays it both ways and checks the report (JSON and text) and the account are the same.
    fn check(&self, tag: &str) {
        let (ended, song, tempo) = self.through_stage();
        let named = !self.outs.is_empty();
        let reports = Reports::of(&ended, named);
        let mut account = Vec::new();
        account::write_accounts(&mut account, &song, &ended, tempo).unwrap();
        let account = String::from_utf8(account).unwrap();
        assert!(
            account.lines().count() > 10,
            "{tag}: an account of a few notes"
        );

        let args = self.args();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let notes = testkit::in_test(&format!("{tag}-notes.jsonl"));
        let (json, notes_file) = orch(&[&args[..], &["--json"]].concat(), Some(&notes));
        assert_eq!(
            json,
            format!("{}\n", serde_json::to_string(&reports).unwrap()),
            "{tag}: the JSON report"
        );
        assert_eq!(notes_file, account, "{tag}: the note-by-note account");
        let (shown, _) = orch(&args, None);
        assert_eq!(
            shown,
            text::reports(&reports, &self.file),
            "{tag}: the report as text"
        );
    }
}

#[test]
fn a_play_through_the_library_gives_orch_plays_report_and_account() {
    Play {
        file: corpus("bach-invention-01.mid"),
        robot: None,
        tempo: 1.0,
        from: None,
        outs: &[],
    }
    .check("plain");
}

#[test]
fn from_a_bar_at_a_tempo_on_a_pwm_robot_the_same() {
    let dir = scratch("pwm");
    let robot = dir.join("robot.toml");
    let toml = Command::cargo_bin("orch")
        .unwrap()
        .args(["config", "--boards", "pca9685"])
        .output()
        .unwrap()
        .stdout;
    std::fs::write(&robot, toml).unwrap();
    Play {
        file: corpus("freedoom1-intro.mid"),
        robot: Some(&robot),
        tempo: 1.3,
        from: Some(5),
        outs: &[],
    }
    .check("pwm");
}

#[test]
fn several_robots_sharing_the_channels_the_same() {
    Play {
        file: corpus("freedoom2-messag.mid"),
        robot: None,
        tempo: 0.8,
        from: None,
        outs: &["sim:ch=1,2", "sim:ch=3-16"],
    }
    .check("robots");
}

#[test]
fn an_analysis_through_the_library_gives_orch_analyzes() {
    let file = corpus("freedoom1-e2m1.mid");
    let song = load_song(&file).unwrap();
    let robot = load_robot(None).unwrap();
    let setup = setup::setup(&robot, true, setup::tempo(1.1).unwrap());
    let (analysis, played) = analyze(&song, &robot, &setup).unwrap();
    assert!(!analysis.went_wrong.is_empty() && analysis.findings.len() > 2);
    let mut account = Vec::new();
    account::write_account(
        &mut account,
        &song,
        &played,
        orch_io::Channels::ALL,
        setup.tempo,
        None,
    )
    .unwrap();

    let path = file.display().to_string();
    let notes = testkit::in_test("notes.jsonl");
    let (shown, notes_file) = orch(&["analyze", &path, "--tempo", "1.1"], Some(&notes));
    assert_eq!(
        shown,
        text::analysis(&analysis, &file),
        "the analysis as text"
    );
    assert_eq!(
        notes_file,
        String::from_utf8(account).unwrap(),
        "the account"
    );

    // The JSON: the report's fields and the notes that go wrong (the findings are the text's).
    let (json, _) = orch(&["analyze", &path, "--tempo", "1.1", "--json"], None);
    let printed: serde_json::Value = serde_json::from_str(&json).unwrap();
    let mut ours = serde_json::to_value(&analysis).unwrap();
    let findings = ours.as_object_mut().unwrap().remove("findings").unwrap();
    assert_eq!(printed, ours, "the analysis as JSON");
    assert_eq!(findings.as_array().unwrap().len(), analysis.findings.len());
}
