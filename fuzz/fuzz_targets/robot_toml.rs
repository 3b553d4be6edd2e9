//! Fuzzes the `orch` program's text readers: `Robot::from_toml` (robot.toml) and
//! `hex::parse_line` (`--hex` input) on any text never panic, an accepted configuration builds
//! an interpreter, and accepted hex round-trips. The checks live in testkit's `fuzz::robot_toml` (crates/testkit/src/fuzz/),
//! which the `orch` package's `tests/fuzz_replay.rs` also uses to replay the corpus and the
//! regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

use testkit::fuzz::robot_toml as check_robot_toml;

fuzz_target!(|data: &[u8]| {
    check_robot_toml::check(data);
});
