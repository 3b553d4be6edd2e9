//! `orch baton`: a generated conductor clip in, one beat a line out; bad input exits 2.

use assert_cmd::Command;
use orch_baton::source::Y4mWriter;
use orch_baton::synth::{Script, Video};
use serde_json::Value;

fn scratch(name: &str) -> testkit::Scratch {
    testkit::Scratch::new(&format!("baton-cli-{name}"))
}

#[test]
fn json_lines_one_per_beat_at_the_true_ictus() {
    let video = Video::new(Script::steady("cli", 160.0, 30.0).beats(5));
    let dir = scratch("json");
    let clip = dir.join("clip.y4m");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&clip).unwrap());
        let mut w = Y4mWriter::new(file, 640, 480, 30.0).unwrap();
        for (_, f) in video.frames() {
            w.write(&f).unwrap();
        }
    }
    let out = Command::cargo_bin("orch")
        .unwrap()
        .args(["baton", "--json"])
        .arg(&clip)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), video.truth.len(), "{text}");
    for (k, (line, truth)) in lines.iter().zip(&video.truth).enumerate() {
        assert!(line.starts_with(r#"{"t_ms":"#), "{line}");
        let v: Value = serde_json::from_str(line).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
        assert_eq!(keys, ["t_ms", "bpm", "x", "y"]);
        let t = v["t_ms"].as_f64().unwrap();
        assert!(
            (t - truth.t_ms).abs() < 15.0, // the suite's p95 at 30 fps is under 8 ms
            "{line} vs {truth:?}"
        );
        assert!(
            (v["x"].as_f64().unwrap() - truth.x).abs() < 6.0,
            "{line} vs {truth:?}"
        );
        assert!(
            (v["y"].as_f64().unwrap() - truth.y).abs() < 6.0,
            "{line} vs {truth:?}"
        );
        if k == 0 {
            assert!(v["bpm"].is_null());
        } else {
            assert!((v["bpm"].as_f64().unwrap() - 160.0).abs() < 3.0, "{line}");
        }
    }
    // Text: the same beats, then a summary.
    let out = Command::cargo_bin("orch")
        .unwrap()
        .arg("baton")
        .arg(&clip)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("beat ")).count(), 5);
    assert!(text.lines().last().unwrap().contains("5 beats"), "{text}");
}

#[test]
fn bad_input_exits_2_with_a_clear_message() {
    let dir = scratch("bad");
    let junk = dir.join("junk.y4m");
    std::fs::write(&junk, "not a video").unwrap();
    let missing = dir.join("missing.y4m");
    let cases: Vec<(Vec<std::ffi::OsString>, &str)> = vec![
        (vec![missing.clone().into()], "no such file"),
        (vec![junk.clone().into()], "YUV4MPEG2"),
        (vec![dir.as_os_str().into()], "--fps"),
        (
            vec![dir.as_os_str().into(), "--fps".into(), "0".into()],
            "--fps",
        ),
        (
            vec![dir.as_os_str().into(), "--fps".into(), "30".into()],
            "no .png",
        ),
    ];
    for (args, says) in cases {
        let out = Command::cargo_bin("orch")
            .unwrap()
            .arg("baton")
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(out.stdout.is_empty());
    }
}
