//! Guards that what the fuzzer learned stays learned: replays every input of
//! `fuzz/corpus/interpret/` (the seeds) and `fuzz/regressions/interpret/` (crashes the fuzzer
//! found) through the fuzz target's own checks, `fuzz/check.rs`, on stable Rust, as part of
//! `cargo test -p orch-core`. Fails if the corpus is missing or empty, so it cannot pass by
//! replaying nothing.

#[path = "../../../fuzz/check.rs"]
mod check;

use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

/// The input files of `dir` (not README.md nor hidden files), sorted.
fn inputs(dir: &Path) -> Vec<PathBuf> {
    let entries =
        std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{} must exist: {e}", dir.display()));
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.expect("readable directory entry").path())
        .filter(|p| p.is_file())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            !name.starts_with('.') && !name.ends_with(".md")
        })
        .collect();
    files.sort();
    files
}

fn replay(files: &[PathBuf]) {
    for file in files {
        let data = std::fs::read(file).unwrap();
        let outcome = std::panic::catch_unwind(|| check::check(&data));
        if let Err(e) = outcome {
            let why = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("{} fails the fuzz checks: {why}", file.display());
        }
    }
}

#[test]
fn the_corpus_replays_clean() {
    let files = inputs(&fuzz_dir().join("corpus/interpret"));
    assert!(
        files.len() >= 10,
        "fuzz/corpus/interpret has {} inputs; the seeds are missing",
        files.len()
    );
    replay(&files);
}

#[test]
fn every_regression_replays_clean() {
    let dir = fuzz_dir().join("regressions/interpret");
    assert!(
        dir.join("README.md").is_file(),
        "{} must exist, with its README",
        dir.display()
    );
    replay(&inputs(&dir));
}

#[test]
fn the_checks_accept_empty_and_tiny_inputs() {
    check::check(&[]);
    check::check(&[0x90]);
    check::check(&[0x00, 0x00, 0x7F, 0x2D]);
    check::check(&[0x00, 0x00, 0x7F, 0x2D, 0x90, 60, 100]);
}
