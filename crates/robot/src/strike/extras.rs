//! A strike group's outputs that no note strikes: leads (an open hi-hat's lift, fired before
//! its stick) and dampers (fired at a bar's or a cymbal's Note-Off).

use orch_core::{Duration, Note, Pulse};

use super::{check, Figures, Read, StrikeFile};
use crate::file::{delay, int};
use crate::RobotError;

/// Reads the `leads`, `lead` and `damps` fields of kit `g`'s outputs (keys from `first`,
/// named `names`) into the core's strikes.
pub(super) fn kit_extras(
    read: &mut Read,
    file: &StrikeFile,
    g: usize,
    first: usize,
    names: &[String],
) -> Result<(), RobotError> {
    let prefix = format!("strike[{g}].");
    for (i, out) in file.output.iter().enumerate() {
        let oprefix = format!("{prefix}output[{i}].");
        let key = (first + i) as u8;
        match (&out.lead, out.leads.is_empty()) {
            (Some(text), false) => {
                let time = delay(&format!("{oprefix}lead"), text)?;
                for (j, &n) in out.leads.iter().enumerate() {
                    let field = format!("{oprefix}leads[{j}]");
                    let note = int(&field, n, 0, 127, "a MIDI note")?;
                    lead(read, g, note, key, time, &field, &oprefix)?;
                }
            }
            (None, false) => {
                return Err(RobotError::field(
                    format!("{oprefix}lead"),
                    "missing: a lead output says how long before the note's own output it fires, such as \"15ms\"",
                ))
            }
            (Some(_), true) => {
                return Err(RobotError::field(
                    format!("{oprefix}leads"),
                    "missing: the notes this output fires before their own output, such as [46]",
                ))
            }
            (None, true) => {}
        }
        if let Some(target) = &out.damps {
            let Some(t) = names.iter().position(|n| n == target) else {
                return Err(RobotError::field(
                    format!("{oprefix}damps"),
                    format!("\"{target}\" is no output of this group"),
                ));
            };
            let bar = (first + t) as u8;
            if read.strikes.damper(bar).is_some() {
                return Err(RobotError::field(
                    format!("{oprefix}damps"),
                    format!("\"{target}\" has a damper already"),
                ));
            }
            read.strikes.set_damper(bar, key);
        }
    }
    Ok(())
}

/// Makes `note` of group `g` fire `lift` `time` before its own output, refusing what the
/// core would.
fn lead(
    read: &mut Read,
    g: usize,
    note: u8,
    lift: u8,
    time: Duration,
    field: &str,
    oprefix: &str,
) -> Result<(), RobotError> {
    let Some(own) = read.strikes.map[g][note as usize].checked_sub(1) else {
        return Err(RobotError::field(
            field,
            format!("note {note} is played by no output of this group"),
        ));
    };
    let rebound = read.strikes.pulse(own).rebound;
    if time == Duration::ZERO || time >= rebound {
        return Err(RobotError::field(
            format!("{oprefix}lead"),
            format!(
                "{} µs: a lead is above 0 and below the rebound of the output it leads ({} µs)",
                time.as_micros(),
                rebound.as_micros()
            ),
        ));
    }
    read.strikes.set_lead(g, Note::from_bits(note), lift, time);
    Ok(())
}

/// A pitched group's dampers: one a bar (`bars` of them, from key `first`), after the bars,
/// each fired for `pulse_text` at its bar's Note-Off. Returns their names.
pub(super) fn bar_dampers(
    read: &mut Read,
    pulse_text: &str,
    prefix: &str,
    first: usize,
    bars: usize,
    figures: Figures,
) -> Result<Vec<String>, RobotError> {
    let field = format!("{prefix}damper_pulse");
    let length = delay(&field, pulse_text)?;
    // A damper presses a felt on the bar and lets go: it may fire again once it is back
    // (its pulse and return), and not sooner than twice its pulse.
    let back = length.as_micros() + figures.mechanics.release_delay.as_micros();
    let pulse = Pulse {
        soft: length,
        loud: length,
        rebound: Duration::from_micros(back.max(length.as_micros().saturating_mul(2))),
    };
    let damper = Figures {
        pulse,
        mechanics: orch_sim::KeyMechanics {
            mute_after: None,
            ..figures.mechanics
        },
    };
    check(&damper, prefix)?;
    if first + 2 * bars > crate::MAX_KEYS {
        return Err(super::too_many(prefix));
    }
    let start = read
        .strikes
        .add_outputs(bars, pulse)
        .map_err(|e| RobotError::field(&field, e.to_string()))?;
    let mut names = Vec::new();
    for b in 0..bars {
        let (bar, d) = ((first + b) as u8, start + b as u8);
        read.strikes.set_damper(bar, d);
        read.mechanics.push((d, damper.mechanics));
        names.push(format!("{} damper", crate::note_name(note_of(read, bar))));
    }
    Ok(names)
}

/// The note a pitched group's bar `key` plays as written.
fn note_of(read: &Read, key: u8) -> u8 {
    let g = read.strikes.groups().last().expect("the group just pushed");
    match g.notes {
        orch_core::StrikeNotes::Range(range, _) => range.low().get() + (key - g.first),
        orch_core::StrikeNotes::Sparse => 0,
    }
}
