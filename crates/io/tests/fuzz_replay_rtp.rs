//! Guards that what the `rtp_packet` fuzzer learned stays learned: replays every input of
//! `fuzz/corpus/rtp_packet/` (the seeds) and `fuzz/regressions/rtp_packet/` through the fuzz
//! target's own checks, testkit's `fuzz::rtp`, on stable Rust. Fails if the corpus is thin, so
//! it cannot pass by replaying nothing, and checks that the seeds named `bad-*` are refused
//! and the others read, so both paths of the readers stay covered.

use orch_io::rtp::{control, journal, packet};
use std::path::{Path, PathBuf};
use testkit::fuzz::replay::{inputs, replay};
use testkit::fuzz::rtp as check_rtp;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

#[test]
fn the_corpus_replays_clean() {
    let files = inputs(&fuzz_dir().join("corpus/rtp_packet"));
    assert!(
        files.len() >= 15,
        "fuzz/corpus/rtp_packet has {} inputs",
        files.len()
    );
    replay(&files, check_rtp::check);
}

#[test]
fn good_seeds_read_and_bad_seeds_are_refused() {
    for file in inputs(&fuzz_dir().join("corpus/rtp_packet")) {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let data = std::fs::read(&file).unwrap();
        let read = if name.starts_with("applemidi-") {
            control::parse(&data).is_ok()
        } else if name.ends_with(".bin") {
            journal::parse(&data).is_ok()
        } else {
            packet::parse(&data).is_ok_and(|p| p.journal.is_none_or(|j| journal::parse(j).is_ok()))
        };
        assert_eq!(read, !name.starts_with("bad-"), "{name}");
    }
}

#[test]
fn every_regression_replays_clean() {
    let dir = fuzz_dir().join("regressions/rtp_packet");
    assert!(
        dir.join("README.md").is_file(),
        "{} and its README",
        dir.display()
    );
    replay(&inputs(&dir), check_rtp::check);
}

/// A poor fuzzer on stable: every seed with bytes flipped, cut, repeated and spliced by a
/// fixed generator (the same every run), through the same checks.
#[test]
fn mutated_seeds_replay_clean() {
    let seeds: Vec<Vec<u8>> = inputs(&fuzz_dir().join("corpus/rtp_packet"))
        .iter()
        .map(|f| std::fs::read(f).unwrap())
        .collect();
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    for _ in 0..200_000 {
        let mut d = seeds[next() as usize % seeds.len()].clone();
        for _ in 0..1 + next() % 4 {
            let at = next() as usize % (d.len() + 1);
            match next() % 5 {
                0 if at < d.len() => d[at] ^= 1 << (next() % 8),
                1 if at < d.len() => d[at] = next() as u8,
                2 => d.truncate(at),
                3 => d.insert(at, next() as u8),
                _ => {
                    let other = &seeds[next() as usize % seeds.len()];
                    let from = next() as usize % (other.len() + 1);
                    d.extend_from_slice(&other[from..]);
                }
            }
        }
        let outcome = std::panic::catch_unwind(|| check_rtp::check(&d));
        assert!(outcome.is_ok(), "fails the checks: {d:02x?}");
    }
}
