//! Guards that what the `robot_toml` fuzzer learned stays learned: replays every input of
//! `fuzz/corpus/robot_toml/` (the seeds) and `fuzz/regressions/robot_toml/` (crashes the
//! fuzzer found) through the fuzz target's own checks, `fuzz/check_robot_toml.rs`, on stable
//! Rust, as part of `cargo test -p orch`. Fails if the corpus is missing or thin, so it cannot
//! pass by replaying nothing, and checks that the good `.toml` seeds are accepted and the
//! `bad-*` ones refused, so both paths of the reader stay covered.

use std::path::{Path, PathBuf};
use testkit::fuzz::replay::{inputs, replay};
use testkit::fuzz::robot_toml as check_robot_toml;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

#[test]
fn the_corpus_replays_clean() {
    let files = inputs(&fuzz_dir().join("corpus/robot_toml"));
    assert!(
        files.len() >= 10,
        "fuzz/corpus/robot_toml has {} inputs; the seeds are missing",
        files.len()
    );
    replay(&files, check_robot_toml::check);
}

#[test]
fn good_seeds_are_accepted_and_bad_seeds_refused() {
    let mut wrong = Vec::new();
    for file in inputs(&fuzz_dir().join("corpus/robot_toml")) {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        if !name.ends_with(".toml") {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        match (
            orch_robot::Robot::from_toml(&text),
            name.starts_with("bad-"),
        ) {
            (Ok(_), true) => wrong.push(format!("{name}: accepted")),
            (Err(e), false) => wrong.push(format!("{name}: refused: {e:#}")),
            _ => {}
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

#[test]
fn the_default_seed_is_the_default_configuration() {
    let seed = std::fs::read_to_string(fuzz_dir().join("corpus/robot_toml/default.toml")).unwrap();
    assert_eq!(seed, orch_robot::DEFAULT_TOML);
}

#[test]
fn every_regression_replays_clean() {
    let dir = fuzz_dir().join("regressions/robot_toml");
    assert!(
        dir.join("README.md").is_file(),
        "{} must exist, with its README",
        dir.display()
    );
    replay(&inputs(&dir), check_robot_toml::check);
}

#[test]
fn the_checks_accept_empty_and_tiny_inputs() {
    check_robot_toml::check(b"");
    check_robot_toml::check(b"\xff\xfe");
    check_robot_toml::check(b"90 3c 7f");
    check_robot_toml::check(b"[keys]\nlow = 60\nhigh = 60\n[[boards]]\naddress = 0x20\nkeys = 1\n");
}
