//! `orch interpret`: raw MIDI bytes through the interpreter and the safety guard, every board
//! write printed as it would go on the bus, then the state of every board after the last
//! byte. The work is `orch_stage::interpret`'s (byte `i` arriving at `i × 320 µs`, timers at
//! their own time); here: the arguments, the guard's override, the printing.

use std::io::{self, BufWriter, Write};

use orch_stage::interpret::Interpretation;
use orch_stage::writes;

use crate::cli::{InterpretArgs, OnOff};
use crate::input;
use crate::robot::Robot;

/// The warning when `--guard` overrides the robot file's `guard.enabled`.
fn guard_override(on: bool, path: &std::path::Path) -> String {
    let (flag, file, now) = if on {
        ("on", "false", "ON: its limits apply")
    } else {
        (
            "off",
            "true",
            "OFF: no hold limit, power budget, re-strike gap or watchdog",
        )
    };
    format!(
        "orch: WARNING: --guard {flag} overrides `enabled = {file}` in [guard] of {}: \
         the safety guard is {now}",
        path.display()
    )
}

pub fn run(args: &InterpretArgs) -> anyhow::Result<()> {
    let mut robot = match &args.robot {
        Some(path) => Robot::load(path)?,
        None => Robot::thesis(),
    };
    if let Some(flag) = args.guard {
        let wanted = flag == OnOff::On;
        if robot.config.guard.enabled != wanted {
            if let Some(path) = &args.robot {
                eprintln!("{}", guard_override(wanted, path));
            }
        }
        robot.config.guard.enabled = wanted;
    }
    let mut interpretation = Interpretation::new(robot)?;
    let mut out = BufWriter::new(io::stdout().lock());
    let json = args.source.json;
    input::for_each_chunk(&args.source, |bytes| {
        for &byte in bytes {
            for w in interpretation.push(byte) {
                if json {
                    writeln!(out, "{}", writes::json(w))?;
                } else {
                    writeln!(out, "{}", writes::text(w))?;
                }
            }
        }
        out.flush()?;
        Ok(())
    })?;
    let end = interpretation.finish();
    if json {
        writeln!(out, "{}", end.json())?;
    } else {
        write!(out, "{}", end.text())?;
    }
    out.flush()?;
    Ok(())
}
