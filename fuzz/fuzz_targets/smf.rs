//! Fuzzes orch-seq's Standard MIDI File reader and the performer's planner on it: `Song::parse`
//! on any bytes never panics, and a song it accepts is in order, counts its notes right and
//! plans (with latency compensation, a re-strike gap and a late limit) as a stream exactly as
//! a whole, sending every message once without reordering a key. The checks live in
//! `../check_smf.rs`, which `crates/perform/tests/fuzz_replay_smf.rs` also uses to replay the
//! corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../check_smf.rs"]
mod check_smf;

fuzz_target!(|data: &[u8]| {
    check_smf::check(data);
});
