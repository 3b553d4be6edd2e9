//! Fuzzes orch-io's RTP-MIDI readers: the RTP-MIDI packet (command section and journal), the
//! recovery journal on its own, a receiver recovering from a loss, and AppleMIDI's session
//! commands; the checks live in testkit's `fuzz::rtp` (crates/testkit/src/fuzz/), which `crates/io/tests/fuzz_replay_rtp.rs`
//! also uses to replay the corpus and the regressions on stable Rust.
#![no_main]

use libfuzzer_sys::fuzz_target;

use testkit::fuzz::rtp as check_rtp;

fuzz_target!(|data: &[u8]| {
    check_rtp::check(data);
});
