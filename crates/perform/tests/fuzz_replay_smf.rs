//! Guards that what the `smf` fuzzer learned stays learned: replays every input of
//! `fuzz/corpus/smf/` (the seeds) and `fuzz/regressions/smf/` (crashes the fuzzer found)
//! through the fuzz target's own checks, testkit's `fuzz::smf`, on stable Rust, as part of
//! `cargo test -p orch-perform` (the checks run orch-seq's reader and this crate's planner). Fails if the corpus is missing or thin, so it cannot pass by
//! replaying nothing, and checks that the whole seeds parse (so the plan checks run) and
//! the damaged ones (`bad-*`, `cut-*`) are refused.

use std::path::{Path, PathBuf};
use testkit::fuzz::replay::{inputs, replay};
use testkit::fuzz::smf as check_smf;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

#[test]
fn the_corpus_replays_clean() {
    let files = inputs(&fuzz_dir().join("corpus/smf"));
    assert!(
        files.len() >= 6,
        "fuzz/corpus/smf has {} inputs; the seeds are missing",
        files.len()
    );
    assert!(
        fuzz_dir().join("corpus/smf/SOURCES.md").is_file(),
        "fuzz/corpus/smf/SOURCES.md must say where the seeds come from"
    );
    replay(&files, check_smf::check);
}

#[test]
fn whole_seeds_parse_and_damaged_seeds_are_refused() {
    let mut wrong = Vec::new();
    let mut whole = 0;
    for file in inputs(&fuzz_dir().join("corpus/smf")) {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let damaged = name.starts_with("bad-") || name.starts_with("cut-");
        let song = orch_seq::Song::parse(&std::fs::read(&file).unwrap());
        match (&song, damaged) {
            (Ok(_), false) => whole += 1,
            (Err(_), true) => {}
            (Ok(s), true) => {
                wrong.push(format!("{name}: damaged but parsed ({} notes)", s.notes()))
            }
            (Err(e), false) => wrong.push(format!("{name}: refused: {e}")),
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    assert!(whole >= 5, "only {whole} whole seeds");
}

fn shared_midi() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    assert!(
        dir.is_dir(),
        "the shared MIDI corpus is missing at {}",
        dir.display()
    );
    dir
}

/// The shared corpus is not copied into the fuzz seeds (its README asks so): its files, and
/// truncations of the small ones, go through the same checks here.
#[test]
fn the_shared_corpus_and_its_truncations_pass_the_fuzz_checks() {
    let files: Vec<PathBuf> = inputs(&shared_midi())
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "mid" || e == "kar"))
        .collect();
    assert!(files.len() > 50);
    for file in &files {
        let data = std::fs::read(file).unwrap();
        check_smf::check(&data);
        if data.len() < 4_000 {
            for cut in (0..data.len()).step_by(37) {
                check_smf::check(&data[..cut]);
            }
        }
    }
}

#[test]
fn every_regression_replays_clean() {
    let dir = fuzz_dir().join("regressions/smf");
    assert!(
        dir.join("README.md").is_file(),
        "{} must exist, with its README",
        dir.display()
    );
    replay(&inputs(&dir), check_smf::check);
}

#[test]
fn the_checks_accept_empty_and_tiny_inputs() {
    check_smf::check(&[]);
    check_smf::check(b"MThd");
    check_smf::check(b"MThd\0\0\0\x06\0\0\0\0\0\x60");
    check_smf::check(b"MThd\0\0\0\x06\0\0\0\x01\0\x60MTrk\0\0\0\x04\0\xff\x2f\0");
}
