//! `[[strike]]`: strike groups (drum kits, glockenspiels) and how they become orch-core's
//! [`Strikes`] and the virtual robot's mechanics of their outputs.

use orch_core::{ChannelMask, Duration, KeyRange, Note, OutOfRange, Pulse, Strikes};
use orch_sim::{KeyMechanics, MechanicsConfig};
use serde::Deserialize;

use crate::file::{channels, delay, int, Policy};
use crate::{Group, GroupKind, RobotError};

mod extras;

/// One `[[strike]]` table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct StrikeFile {
    name: Option<String>,
    #[serde(default = "all_channels")]
    channels: toml::Value,
    /// A pitched group's notes (both or neither).
    low: Option<i64>,
    high: Option<i64>,
    out_of_range: Option<Policy>,
    /// The General MIDI program (1..=128) `orch render` plays a pitched group with.
    program: Option<i64>,
    pulse_soft: Option<String>,
    pulse_loud: Option<String>,
    rebound: Option<String>,
    flight: Option<String>,
    soft_flight: Option<String>,
    min_pulse: Option<String>,
    return_delay: Option<String>,
    mute_after: Option<String>,
    /// A pitched group's dampers: one a bar, after the bars, each fired for this pulse at
    /// its bar's Note-Off.
    damper_pulse: Option<String>,
    #[serde(default)]
    output: Vec<OutputFile>,
}

fn all_channels() -> toml::Value {
    toml::Value::String("all".into())
}

/// One `[[strike.output]]` of an unpitched group: an output, the notes it plays and the
/// figures where it differs from its group.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct OutputFile {
    name: Option<String>,
    #[serde(default)]
    notes: Vec<i64>,
    /// The notes this output fires before their own output (an open hi-hat's lift).
    #[serde(default)]
    leads: Vec<i64>,
    /// How long before their own output it fires them.
    lead: Option<String>,
    /// The output (by name) whose notes' Note-Offs fire this one: its damper.
    damps: Option<String>,
    pulse_soft: Option<String>,
    pulse_loud: Option<String>,
    rebound: Option<String>,
    flight: Option<String>,
    soft_flight: Option<String>,
    min_pulse: Option<String>,
    return_delay: Option<String>,
    mute_after: Option<String>,
}

/// An output's figures: its pulse (core) and its beater's mechanics (virtual robot).
#[derive(Clone, Copy)]
pub(crate) struct Figures {
    pub pulse: Pulse,
    pub mechanics: KeyMechanics,
}

/// The figures a field left out takes: a drum's (see `Pulse::DRUM` and the text
/// `orch config --instrument drums` prints).
const DEFAULT_FIGURES: Figures = Figures {
    pulse: Pulse::DRUM,
    mechanics: KeyMechanics {
        press_delay: Duration::from_millis(10),
        release_delay: Duration::from_millis(15),
        min_hold: Duration::from_millis(4),
        softest: KeyMechanics::DEFAULT.softest,
        soft_press_delay: Duration::from_millis(20),
        mute_after: Some(Duration::from_millis(20)),
    },
};

/// The figure fields of a table, as written.
struct Written<'a> {
    pulse_soft: &'a Option<String>,
    pulse_loud: &'a Option<String>,
    rebound: &'a Option<String>,
    flight: &'a Option<String>,
    soft_flight: &'a Option<String>,
    min_pulse: &'a Option<String>,
    return_delay: &'a Option<String>,
    mute_after: &'a Option<String>,
}

impl Written<'_> {
    /// `base` with the fields given here; `prefix` names the table (`strike[0].`).
    fn over(&self, base: Figures, prefix: &str) -> Result<Figures, RobotError> {
        let mut f = base;
        let read = |name: &str, text: &Option<String>, into: &mut Duration| {
            if let Some(t) = text {
                *into = delay(&format!("{prefix}{name}"), t)?;
            }
            Ok::<_, RobotError>(())
        };
        read("pulse_soft", self.pulse_soft, &mut f.pulse.soft)?;
        read("pulse_loud", self.pulse_loud, &mut f.pulse.loud)?;
        read("rebound", self.rebound, &mut f.pulse.rebound)?;
        read("flight", self.flight, &mut f.mechanics.press_delay)?;
        read(
            "soft_flight",
            self.soft_flight,
            &mut f.mechanics.soft_press_delay,
        )?;
        read("min_pulse", self.min_pulse, &mut f.mechanics.min_hold)?;
        read(
            "return_delay",
            self.return_delay,
            &mut f.mechanics.release_delay,
        )?;
        if let Some(t) = self.mute_after {
            f.mechanics.mute_after = Some(delay(&format!("{prefix}mute_after"), t)?);
        }
        check(&f, prefix)?;
        Ok(f)
    }
}

/// Refuses figures no beater can play: a pulse of 0, a loud pulse shorter than the soft, a
/// rebound shorter than the loud pulse, a soft pulse too short to sound.
fn check(f: &Figures, prefix: &str) -> Result<(), RobotError> {
    let ms = |d: Duration| format!("{}ms", d.as_micros() as f64 / 1000.0);
    let p = f.pulse;
    if p.soft == Duration::ZERO {
        return Err(RobotError::field(
            format!("{prefix}pulse_soft"),
            "0ms: a strike needs a pulse; give one such as \"8ms\"",
        ));
    }
    if p.loud < p.soft {
        return Err(RobotError::field(
            format!("{prefix}pulse_loud"),
            format!(
                "{} is shorter than pulse_soft = {}: louder notes would strike weaker",
                ms(p.loud),
                ms(p.soft)
            ),
        ));
    }
    if p.rebound < p.loud {
        return Err(RobotError::field(
            format!("{prefix}rebound"),
            format!(
                "{} is shorter than pulse_loud = {}: a beater cannot strike again before its pulse ends",
                ms(p.rebound),
                ms(p.loud)
            ),
        ));
    }
    let back = p.loud.as_micros() + f.mechanics.release_delay.as_micros();
    if p.rebound.as_micros() < back {
        return Err(RobotError::field(
            format!("{prefix}rebound"),
            format!(
                "{} is shorter than pulse_loud + return_delay = {}: the beater would fire again before it is back",
                ms(p.rebound),
                ms(Duration::from_micros(back))
            ),
        ));
    }
    if p.soft < f.mechanics.min_hold {
        return Err(RobotError::field(
            format!("{prefix}pulse_soft"),
            format!(
                "{} is shorter than min_pulse = {}: a soft strike would fire a blank",
                ms(p.soft),
                ms(f.mechanics.min_hold)
            ),
        ));
    }
    Ok(())
}

/// The figure fields of a `[[strike]]` or `[[strike.output]]` table, which both have them (serde
/// cannot flatten one struct into both while refusing unknown fields).
macro_rules! written {
    ($table:ty) => {
        impl $table {
            fn written(&self) -> Written<'_> {
                Written {
                    pulse_soft: &self.pulse_soft,
                    pulse_loud: &self.pulse_loud,
                    rebound: &self.rebound,
                    flight: &self.flight,
                    soft_flight: &self.soft_flight,
                    min_pulse: &self.min_pulse,
                    return_delay: &self.return_delay,
                    mute_after: &self.mute_after,
                }
            }
        }
    };
}

written!(StrikeFile);
written!(OutputFile);

/// The strike groups read: the core's [`Strikes`], the groups as the robot describes them,
/// and their outputs' mechanics (by key).
pub(crate) struct Read {
    pub strikes: Strikes,
    pub groups: Vec<Group>,
    pub mechanics: Vec<(u8, KeyMechanics)>,
}

/// Reads every `[[strike]]` table, their outputs numbered from `first` (the keyboard's key
/// count, or 0 without one).
pub(crate) fn read(
    files: &[StrikeFile],
    keyboard: bool,
    keyboard_keys: usize,
) -> Result<Read, RobotError> {
    let mut read = Read {
        strikes: Strikes {
            keyboard,
            ..Strikes::NONE
        },
        groups: Vec::new(),
        mechanics: Vec::new(),
    };
    if files.len() > orch_core::strike::MAX_STRIKE_GROUPS {
        return Err(RobotError::field(
            "strike",
            format!(
                "{} strike groups; a robot has at most {}",
                files.len(),
                orch_core::strike::MAX_STRIKE_GROUPS
            ),
        ));
    }
    for (g, file) in files.iter().enumerate() {
        let prefix = format!("strike[{g}].");
        let first = read.strikes.outputs() + if keyboard { keyboard_keys } else { 0 };
        let mask = channels(&file.channels, &format!("{prefix}channels"))?;
        let figures = file.written().over(DEFAULT_FIGURES, &prefix)?;
        let name = file
            .name
            .clone()
            .unwrap_or_else(|| format!("strike {}", g + 1));
        let group = match (file.low, file.high) {
            (None, None) => kit(&mut read, file, g, mask, first, figures)?,
            (Some(low), Some(high)) => {
                pitched(&mut read, file, (low, high), mask, first, figures)?
            }
            _ => {
                return Err(RobotError::field(
                    format!("{prefix}low"),
                    "a pitched group gives both low and high; a drum kit neither (its outputs name their notes)",
                ))
            }
        };
        read.groups.push(Group { name, ..group });
    }
    Ok(read)
}

/// Too many outputs for one robot.
fn too_many(prefix: &str) -> RobotError {
    RobotError::field(
        format!("{prefix}output"),
        format!("a robot has at most {} outputs in all", crate::MAX_KEYS),
    )
}

/// An unpitched group: its `[[strike.output]]` tables.
fn kit(
    read: &mut Read,
    file: &StrikeFile,
    g: usize,
    mask: ChannelMask,
    first: usize,
    group_figures: Figures,
) -> Result<Group, RobotError> {
    let prefix = format!("strike[{g}].");
    if file.output.is_empty() {
        return Err(RobotError::field(
            format!("{prefix}output"),
            "a drum kit needs [[strike.output]] tables: each names its notes (or give low and high for a pitched group)",
        ));
    }
    if file.program.is_some() {
        return Err(RobotError::field(
            format!("{prefix}program"),
            "a drum kit plays General MIDI's drum kit; program is for a pitched group",
        ));
    }
    if file.damper_pulse.is_some() {
        return Err(RobotError::field(
            format!("{prefix}damper_pulse"),
            "a pitched group's dampers; a kit's damper is a [[strike.output]] with damps = \"its drum\"",
        ));
    }
    let mut outputs = Vec::new();
    let mut notes_of = Vec::new();
    let mut seen = [None::<usize>; 128];
    for (i, out) in file.output.iter().enumerate() {
        let oprefix = format!("{prefix}output[{i}].");
        let figures = out.written().over(group_figures, &oprefix)?;
        let extra = !out.leads.is_empty() || out.lead.is_some() || out.damps.is_some();
        if out.notes.is_empty() != extra {
            return Err(RobotError::field(
                format!("{oprefix}notes"),
                if extra {
                    "a lead or a damper (leads, damps) plays no notes of its own"
                } else {
                    "[]: an output plays at least one note, or leads some (leads) or damps one (damps)"
                },
            ));
        }
        let figures = if extra {
            // A lift or a damper does not touch a head or a bar: nothing to mute.
            Figures {
                mechanics: KeyMechanics {
                    mute_after: None,
                    ..figures.mechanics
                },
                ..figures
            }
        } else {
            figures
        };
        let mut notes = Vec::new();
        for (j, &n) in out.notes.iter().enumerate() {
            let note = int(&format!("{oprefix}notes[{j}]"), n, 0, 127, "a MIDI note")?;
            if let Some(other) = seen[note as usize] {
                return Err(RobotError::field(
                    format!("{oprefix}notes[{j}]"),
                    format!("note {note} is already played by {prefix}output[{other}]"),
                ));
            }
            seen[note as usize] = Some(i);
            notes.push(note);
        }
        let key = u8::try_from(first + i).map_err(|_| too_many(&prefix))?;
        read.mechanics.push((key, figures.mechanics));
        outputs.push(
            out.name
                .clone()
                .unwrap_or_else(|| format!("output {}", i + 1)),
        );
        notes_of.push((notes, figures.pulse));
    }
    let list: Vec<(&[u8], Pulse)> = notes_of.iter().map(|(n, p)| (&n[..], *p)).collect();
    read.strikes
        .push_kit(mask, first, &list)
        .map_err(|e| RobotError::field(format!("{prefix}output"), e.to_string()))?;
    extras::kit_extras(read, file, g, first, &outputs)?;
    Ok(Group {
        name: String::new(),
        kind: GroupKind::Kit,
        first: first as u8,
        outputs,
        notes: notes_of.into_iter().map(|(n, _)| n).collect(),
        program: None,
    })
}

/// A pitched group: one output a note of `low..=high`.
fn pitched(
    read: &mut Read,
    file: &StrikeFile,
    (low, high): (i64, i64),
    mask: ChannelMask,
    first: usize,
    figures: Figures,
) -> Result<Group, RobotError> {
    let g = read.groups.len();
    let prefix = format!("strike[{g}].");
    if !file.output.is_empty() {
        return Err(RobotError::field(
            format!("{prefix}output"),
            "a pitched group (low and high) has one output a note; [[strike.output]] is for a drum kit",
        ));
    }
    let lo = int(&format!("{prefix}low"), low, 0, 127, "a MIDI note")?;
    let hi = int(&format!("{prefix}high"), high, 0, 127, "a MIDI note")?;
    let range = KeyRange::new(Note::from_bits(lo), Note::from_bits(hi)).ok_or_else(|| {
        RobotError::field(format!("{prefix}low"), format!("{lo} is above high = {hi}"))
    })?;
    let policy = match file.out_of_range.unwrap_or(Policy::Fold) {
        Policy::Fold => OutOfRange::Fold,
        Policy::Drop => OutOfRange::Drop,
    };
    let program = match file.program {
        Some(p) => int(
            &format!("{prefix}program"),
            p,
            1,
            128,
            "a General MIDI program",
        )?,
        None => 10, // glockenspiel
    };
    if first + range.keys() > crate::MAX_KEYS {
        return Err(too_many(&prefix));
    }
    read.strikes
        .push_pitched(mask, first, range, policy, figures.pulse)
        .map_err(|e| RobotError::field(format!("{prefix}low"), e.to_string()))?;
    for k in 0..range.keys() {
        read.mechanics.push(((first + k) as u8, figures.mechanics));
    }
    let mut outputs: Vec<String> = (lo..=hi).map(crate::note_name).collect();
    let mut notes: Vec<Vec<u8>> = (lo..=hi).map(|n| vec![n]).collect();
    if let Some(text) = &file.damper_pulse {
        let names = extras::bar_dampers(read, text, &prefix, first, range.keys(), figures)?;
        outputs.extend(names);
        notes.resize(outputs.len(), Vec::new());
    }
    Ok(Group {
        name: String::new(),
        kind: GroupKind::Pitched,
        first: first as u8,
        outputs,
        notes,
        program: Some(program),
    })
}

/// The mechanics of the keyboard's keys, with the strike outputs' figures added.
pub(crate) fn with_outputs(
    mut mechanics: MechanicsConfig,
    outputs: &[(u8, KeyMechanics)],
) -> MechanicsConfig {
    for &(key, figures) in outputs {
        mechanics = mechanics.with_key(key, figures);
    }
    mechanics
}

/// The `[[strike]]` field at fault when the core refuses a strike output (its pulse longer
/// than `guard.max_pulse`), if it is one.
pub(crate) fn named(e: orch_core::ConfigError, groups: &[Group]) -> Option<RobotError> {
    let orch_core::ConfigError::Strike(orch_core::StrikeError::PulseTooLong { key }) = e else {
        return None;
    };
    let strikes = groups.iter().filter(|g| g.kind.strikes());
    let (g, group) = strikes.enumerate().find(|(_, g)| g.keys().contains(&key))?;
    let field = match group.kind {
        crate::GroupKind::Kit => format!("strike[{g}].output[{}].pulse_loud", key - group.first),
        _ => format!("strike[{g}].pulse_loud"),
    };
    Some(RobotError::field(
        field,
        format!(
            "the pulse of {} is longer than guard.max_pulse: a beater left on its bar mutes it; make it shorter or raise max_pulse (at most 250ms)",
            group.output_name(key).unwrap_or("this output")
        ),
    ))
}
