//! `orch interpret`: raw MIDI bytes through the interpreter and the safety guard, every board
//! write printed as it would go on the bus.
//!
//! Raw bytes carry no time, so byte `i` is taken to arrive at `i × 320 µs`: back to back at DIN
//! wire speed from t = 0. Timer-driven writes (hold limit, delayed re-strike, watchdog) are
//! printed at their own time with no byte index. The last line is the state of every board
//! after the last byte.

use std::io::{self, BufWriter, Write};

use orch_core::{BoardId, Duty, FingerBoards, Instant};
use orch_robot::BoardKind;
use serde_json::json;

use crate::cli::{InterpretArgs, OnOff};
use crate::input;
use crate::robot::Robot;

/// One DIN MIDI byte on the wire: 10 bits at 31250 baud.
pub const DIN_BYTE_MICROS: u64 = 320;

/// Prints board writes; the caller says when and why they happen.
struct Printer<W: Write> {
    out: W,
    json: bool,
    t: Instant,
    byte: Option<u64>,
    /// What each board is (by index): PWM boards print their duties.
    kinds: Vec<BoardKind>,
}

impl<W: Write> Printer<W> {
    fn cause(&self) -> String {
        match self.byte {
            Some(i) => format!("byte {i}"),
            None => "timer".to_string(),
        }
    }
}

impl<W: Write> FingerBoards for Printer<W> {
    type Error = io::Error;

    fn write_board(&mut self, board: BoardId, outputs: u16) -> io::Result<()> {
        if self.json {
            let line = json!({"t_us": self.t.as_micros(), "byte": self.byte, "address": board.address, "outputs": outputs});
            writeln!(self.out, "{line}")
        } else {
            let cause = self.cause();
            let fingers: String = (0..16)
                .map(|b| if outputs & (1 << b) != 0 { '#' } else { '.' })
                .collect();
            writeln!(
                self.out,
                "{:>11.3} ms  {cause:<11} {:#04x} <- {outputs:#06x}  |{fingers}|",
                self.t.as_micros() as f64 / 1000.0,
                board.address
            )
        }
    }

    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> io::Result<()> {
        if self.kinds.get(board.index as usize) != Some(&BoardKind::Pwm) {
            return self.write_board(board, orch_core::on_off(duties));
        }
        let values: Vec<u16> = duties.iter().map(|d| d.get()).collect();
        if self.json {
            let line = json!({"t_us": self.t.as_micros(), "byte": self.byte, "address": board.address, "duty": values});
            writeln!(self.out, "{line}")
        } else {
            let cause = self.cause();
            writeln!(
                self.out,
                "{:>11.3} ms  {cause:<11} {:#04x} <- duty {}",
                self.t.as_micros() as f64 / 1000.0,
                board.address,
                duty_text(duties)
            )
        }
    }
}

/// A PWM board's duties as people read them: each output that is on, with its duty in per
/// cent ("8:100% 12:35%"), or "all off".
fn duty_text(duties: &[Duty; 16]) -> String {
    let on: Vec<String> = duties
        .iter()
        .enumerate()
        .filter(|(_, d)| d.get() > 0)
        .map(|(n, d)| format!("{n}:{:.0}%", d.percent()))
        .collect();
    if on.is_empty() {
        "all off".to_string()
    } else {
        on.join(" ")
    }
}

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
    let mut interp = robot.interpreter()?;
    let stdout = io::stdout();
    let mut printer = Printer {
        out: BufWriter::new(stdout.lock()),
        json: args.source.json,
        t: Instant::ZERO,
        byte: None,
        kinds: robot.kinds.clone(),
    };
    // A robot with PWM boards is written duties (strike, then hold); on/off boards their bits.
    let pwm = robot.has_dynamics();
    let flush = |interp: &mut crate::robot::HostInterpreter, printer: &mut Printer<_>| {
        if pwm {
            interp.flush_duties(printer).map_err(|e| e.error)
        } else {
            interp.flush(printer).map_err(|e| e.error)
        }
    };
    let mut index: u64 = 0;
    input::for_each_chunk(&args.source, |bytes| {
        for &byte in bytes {
            let now = Instant::from_micros(index * DIN_BYTE_MICROS);
            // Timers due before (or at) this byte's arrival fire first, on their own.
            while let Some(due) = interp.next_deadline().filter(|&d| d <= now) {
                interp.tick(due);
                printer.t = due;
                printer.byte = None;
                flush(&mut interp, &mut printer)?;
                if interp.next_deadline() == Some(due) {
                    break;
                }
            }
            interp.feed(byte, now);
            printer.t = now;
            printer.byte = Some(index);
            flush(&mut interp, &mut printer)?;
            index += 1;
        }
        printer.out.flush()?;
        Ok(())
    })?;
    // Whether the end of the input cut a message off (as `orch decode` says it).
    let truncated = interp.input_ended();
    let layout = &interp.config().layout;
    let boards = &layout.boards[..robot.boards];
    let mut out = printer.out;
    let duties = interp.duties();
    let is_pwm = |i: usize| robot.kinds.get(i) == Some(&BoardKind::Pwm);
    if args.source.json {
        let list: Vec<_> = boards
            .iter()
            .enumerate()
            .map(|(i, b)| {
                if is_pwm(i) {
                    let values: Vec<u16> = duties[i].iter().map(|d| d.get()).collect();
                    json!({"address": b.address, "outputs": interp.frame().outputs(i), "duty": values})
                } else {
                    json!({"address": b.address, "outputs": interp.frame().outputs(i)})
                }
            })
            .collect();
        writeln!(out, "{}", json!({"type": "final", "boards": list}))?;
    } else {
        let s = interp.stats();
        let c = interp.counters();
        writeln!(
            out,
            "# {} bytes, {} messages, {} dropped, {} abandoned, {} truncated",
            c.bytes,
            c.messages,
            c.dropped,
            c.abandoned,
            u8::from(truncated)
        )?;
        writeln!(
            out,
            "# {} notes: {} sounded ({} of them folded, {} joined a key already down), {} dropped (channel {}, range {}, power {}, too fast {}, cancelled {}, stopped {}); {} re-strikes waited for their key's rest; cut: {} by the hold limit, {} by the duty limit, {} by the watchdog; at most {} keys down",
            s.note_ons,
            s.played + s.folded,
            s.folded,
            s.joined,
            s.dropped(),
            s.dropped_channel,
            s.dropped_range,
            s.dropped_power,
            s.dropped_too_fast,
            s.dropped_cancelled,
            s.dropped_stopped,
            s.restrikes_delayed,
            s.cut_by_hold_limit,
            s.cut_by_duty_limit,
            s.cut_by_watchdog,
            s.peak_keys_down
        )?;
        let finals: Vec<String> = boards
            .iter()
            .enumerate()
            .map(|(i, b)| {
                if is_pwm(i) {
                    format!("{:#04x}=[{}]", b.address, duty_text(&duties[i]))
                } else {
                    format!("{:#04x}={:#06x}", b.address, interp.frame().outputs(i))
                }
            })
            .collect();
        writeln!(out, "# final: {}", finals.join(" "))?;
    }
    out.flush()?;
    Ok(())
}
