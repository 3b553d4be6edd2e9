//! Fuzzes orch-seq's Standard MIDI File reader and the performer's planner on it: `Song::parse`
//! on any bytes never panics, and a song it accepts is in order, counts its notes right and
//! plans (with latency compensation, a re-strike gap and a late limit) as a stream exactly as
//! a whole, sending every message once without reordering a key. The checks live in
//! testkit's `fuzz::smf` (crates/testkit/src/fuzz/), which `crates/perform/tests/fuzz_replay_smf.rs` also uses to replay the
//! corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

use testkit::fuzz::smf as check_smf;

fuzz_target!(|data: &[u8]| {
    check_smf::check(data);
});
