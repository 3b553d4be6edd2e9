//! Fuzzes orch-seq's Standard MIDI File reader and the schedule built on it: `Song::parse` on
//! any bytes never panics, and a song it accepts is in order, counts its notes right and
//! schedules (with latency compensation and a re-strike gap) without reordering a key. The
//! checks live in `../check_smf.rs`, which `crates/seq/tests/fuzz_replay.rs` also uses to
//! replay the corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../check_smf.rs"]
mod check_smf;

fuzz_target!(|data: &[u8]| {
    check_smf::check(data);
});
