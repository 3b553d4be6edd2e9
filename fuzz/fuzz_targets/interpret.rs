//! Fuzzes the whole of orch-core with invariants, not only for panics: the decoder's chunking
//! and counters, the interpreter fed byte by byte against burst by burst, the safety guard's
//! limits read from the board writes, and `all_off`. The checks live in `../check.rs`, which
//! `crates/core/tests/fuzz_replay.rs` also uses to replay the corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../check.rs"]
mod check;

fuzz_target!(|data: &[u8]| {
    check::check(data);
});
