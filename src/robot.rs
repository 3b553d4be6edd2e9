//! `robot.toml` on the command line: the [`orch_robot`] library, and `orch config`.
//!
//! The configuration itself (reading, checking, the default file) lives in the `orch-robot`
//! crate; its names are re-exported here so the program's modules say `crate::robot::Robot`.

pub use orch_robot::{HostInterpreter, Robot, RobotError, DEFAULT_TOML, MAX_BOARDS, MAX_KEYS};

/// `orch config [--instrument NAME] [--boards KIND]`: prints the complete configuration of
/// that instrument on that kind of board, commented.
pub fn print_default(instrument: &str, boards: &str) -> anyhow::Result<()> {
    use orch_robot::{BoardKind, Instrument};
    use std::io::Write;
    let kind = if boards == "pca9685" {
        BoardKind::Pwm
    } else {
        BoardKind::OnOff
    };
    let instrument = Instrument::ALL
        .into_iter()
        .find(|i| i.name() == instrument)
        .ok_or_else(|| anyhow::anyhow!("no instrument {instrument:?}"))?;
    let mut out = std::io::stdout().lock();
    out.write_all(orch_robot::instrument_toml(instrument, kind).as_bytes())?;
    Ok(())
}
