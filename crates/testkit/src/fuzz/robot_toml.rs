//! The invariants the `robot_toml` fuzz target checks, shared with the stable-Rust test
//! `tests/fuzz_replay.rs` (the `orch` package), which replays the corpus and the regressions
//! with it. Both use it from here (testkit's `fuzz-robot-toml` feature).
//!
//! An input is text: bytes that are not UTF-8 are replaced (U+FFFD), so every input is
//! checked. The same text goes through both of the `orch` program's text readers:
//!
//! - `orch_robot::Robot::from_toml` (a `robot.toml`) returns, `Ok` or `Err`, and never
//!   panics; on `Ok` the robot is usable: `interpreter()` builds, `sim_config()` has as many
//!   boards as the robot, `write_micros()` is a positive finite time;
//! - `orch_stage::hex::parse_line` (the `--hex` input), line by line, returns and never panics; a
//!   line it accepts, written back as plain hex pairs, parses to the same bytes, and so do
//!   the same bytes written as `0x`-prefixed, comma-separated tokens with a comment.

use std::fmt::Write;

use orch_robot::Robot;
use orch_stage::hex::parse_line;

/// Checks every invariant on one input. Panics on a violation.
pub fn check(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    check_robot(&text);
    for (i, line) in text.lines().enumerate() {
        check_hex_line(line, i + 1);
    }
    // `lines()` splits at `\n` only (and strips a `\r` before it): also the text as one line.
    check_hex_line(&text, 0);
}

fn check_robot(text: &str) {
    let Ok(robot) = Robot::from_toml(text) else {
        return;
    };
    if let Err(e) = robot.interpreter() {
        panic!("from_toml accepted a configuration the interpreter refuses: {e:#}");
    }
    assert!(
        (1..=orch_robot::MAX_BOARDS).contains(&robot.boards),
        "{} boards",
        robot.boards
    );
    assert_eq!(robot.sim_config().boards.len(), robot.boards);
    let w = robot.write_micros();
    assert!(w.is_finite() && w > 0.0, "a board write takes {w} µs");
}

fn check_hex_line(line: &str, line_no: usize) {
    let mut out = vec![0xA5];
    let parsed = parse_line(line, line_no, &mut out);
    let Ok(()) = parsed else {
        return;
    };
    assert_eq!(out[0], 0xA5, "parse_line changed bytes it was given");
    let bytes = &out[1..];

    let mut plain = String::new();
    for b in bytes {
        write!(plain, "{b:02x} ").expect("writing to a String");
    }
    let mut back = Vec::new();
    parse_line(&plain, line_no, &mut back)
        .unwrap_or_else(|e| panic!("its own hex {plain:?} is refused: {e:#}"));
    assert_eq!(back, bytes, "{line:?} → {plain:?} parses to other bytes");

    let mut fancy = String::new();
    for b in bytes {
        write!(fancy, "0X{b:02X},").expect("writing to a String");
    }
    fancy.push_str("# comment 0x zz");
    let mut back = Vec::new();
    parse_line(&fancy, line_no, &mut back)
        .unwrap_or_else(|e| panic!("its own hex {fancy:?} is refused: {e:#}"));
    assert_eq!(back, bytes, "{line:?} → {fancy:?} parses to other bytes");
}
