//! Guards that what the fuzzer learned stays learned: replays every input of
//! `fuzz/corpus/interpret/` (the seeds) and `fuzz/regressions/interpret/` (crashes the fuzzer
//! found) through the fuzz target's own checks (testkit's `fuzz::interpret`), on stable Rust, as part of
//! `cargo test -p orch-core`. Fails if the corpus is missing or empty, so it cannot pass by
//! replaying nothing.

use std::path::{Path, PathBuf};
use testkit::fuzz::interpret as check;
use testkit::fuzz::replay::{inputs, replay};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

#[test]
fn the_corpus_replays_clean() {
    let files = inputs(&fuzz_dir().join("corpus/interpret"));
    assert!(
        files.len() >= 10,
        "fuzz/corpus/interpret has {} inputs; the seeds are missing",
        files.len()
    );
    replay(&files, check::check);
}

#[test]
fn every_regression_replays_clean() {
    let dir = fuzz_dir().join("regressions/interpret");
    assert!(
        dir.join("README.md").is_file(),
        "{} must exist, with its README",
        dir.display()
    );
    replay(&inputs(&dir), check::check);
}

#[test]
fn the_checks_accept_empty_and_tiny_inputs() {
    check::check(&[]);
    check::check(&[0x90]);
    check::check(&[0x00, 0x00, 0x7F, 0x2D]);
    check::check(&[0x00, 0x00, 0x7F, 0x2D, 0x90, 60, 100]);
}
