//! Fuzzes the whole of orch-core with invariants, not only for panics: the decoder's chunking
//! and counters, the interpreter fed byte by byte against burst by burst, the safety guard's
//! limits read from the board writes, and `all_off`. The checks live in testkit's `fuzz::interpret` (crates/testkit/src/fuzz/), which
//! `crates/core/tests/fuzz_replay.rs` also uses to replay the corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

use testkit::fuzz::interpret as check;

fuzz_target!(|data: &[u8]| {
    check::check(data);
});
