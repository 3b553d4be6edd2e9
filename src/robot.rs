//! `robot.toml` on the command line: the [`orch_robot`] library, and `orch config`.
//!
//! The configuration itself (reading, checking, the default file) lives in the `orch-robot`
//! crate; its names are re-exported here so the program's modules say `crate::robot::Robot`.

pub use orch_robot::{HostInterpreter, Robot, RobotError, DEFAULT_TOML, MAX_BOARDS, MAX_KEYS};

/// `orch config`: prints the default configuration, commented.
pub fn print_default() -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(DEFAULT_TOML.as_bytes())?;
    Ok(())
}
