//! `robot.toml` on the command line: the [`orch_robot`] library, and `orch config`.
//!
//! The configuration itself (reading, checking, the default file) lives in the `orch-robot`
//! crate; its names are re-exported here so the program's modules say `crate::robot::Robot`.

pub use orch_robot::{HostInterpreter, Robot, RobotError, DEFAULT_TOML, MAX_BOARDS, MAX_KEYS};

/// `orch config [--boards KIND]`: prints the default configuration for that kind of board,
/// commented.
pub fn print_default(boards: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let kind = if boards == "pca9685" {
        orch_robot::BoardKind::Pwm
    } else {
        orch_robot::BoardKind::OnOff
    };
    let mut out = std::io::stdout().lock();
    out.write_all(orch_robot::default_toml(kind).as_bytes())?;
    Ok(())
}
