//! `[[fingered]]`: a wind robot's group (a recorder, a flute) and how it becomes orch-core's
//! [`Wind`] and the virtual robot's mechanics of its valve and fingers.

use orch_core::{ChannelMask, Duration, Fingering, KeyRange, Note, OutOfRange, Voice, Wind};
use orch_sim::{Breath, KeyMechanics, WindMechanics};
use serde::Deserialize;

use crate::file::{channels, delay, duty, int, Policy};
use crate::{Group, GroupKind, RobotError};

/// The one `[[fingered]]` table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FingeredFile {
    name: Option<String>,
    #[serde(default = "melodic")]
    channels: toml::Value,
    /// The General MIDI program (1..=128) `orch render` plays it with (75: recorder).
    program: Option<i64>,
    voice: Option<String>,
    out_of_range: Option<Policy>,
    /// The finger outputs' names, in board order after the valve.
    fingers: Vec<String>,
    close: Option<String>,
    settle: Option<String>,
    air: Option<String>,
    #[serde(default)]
    note: Vec<NoteFile>,
}

fn melodic() -> toml::Value {
    toml::Value::String("melodic".into())
}

/// One `[[fingered.note]]`: a note's fingering and breath.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NoteFile {
    note: i64,
    /// The fingers closed, by name, separated by spaces; "" for none.
    fingers: String,
    /// The valve's duty for it at velocity 127.
    breath: Option<String>,
}

/// A fingered group read: the core's group, the robot's description and its outputs'
/// mechanics (by key).
pub(crate) struct Read {
    pub wind: Wind,
    pub group: Group,
    pub mechanics: Vec<(u8, KeyMechanics)>,
    /// The virtual robot's view of it: its valve, fingers and table (its cracks and breath).
    pub sim: WindMechanics,
}

/// The defaults: the valve closes in 5 ms, fingers settle in 30 ms (a solenoid's travel and
/// bounce, where glloq's servo flute needs 105 ms), the air sounds 15 ms after the valve opens.
const CLOSE: &str = "5ms";
const SETTLE: &str = "30ms";
const AIR: &str = "15ms";

/// Reads the `[[fingered]]` tables (at most one), its outputs from key `first`.
pub(crate) fn read(files: &[FingeredFile], first: usize) -> Result<Option<Read>, RobotError> {
    match files {
        [] => Ok(None),
        [file] => one(file, first).map(Some),
        _ => Err(RobotError::field(
            "fingered",
            format!("{} fingered groups; a robot has at most one", files.len()),
        )),
    }
}

fn one(file: &FingeredFile, first: usize) -> Result<Read, RobotError> {
    let p = "fingered[0].";
    let fingers = &file.fingers;
    if fingers.is_empty() || fingers.len() > orch_core::wind::MAX_FINGERS {
        return Err(RobotError::field(
            format!("{p}fingers"),
            format!(
                "{} names: a fingered group has 1 to {} finger outputs",
                fingers.len(),
                orch_core::wind::MAX_FINGERS
            ),
        ));
    }
    if first + 1 + fingers.len() > crate::MAX_KEYS {
        return Err(RobotError::field(
            format!("{p}fingers"),
            format!("a robot has at most {} outputs in all", crate::MAX_KEYS),
        ));
    }
    let (range, table) = table(file, p)?;
    let wind = Wind {
        channels: channels(&file.channels, &format!("{p}channels"))?,
        first: first as u8,
        fingers: fingers.len() as u8,
        range,
        out_of_range: match file.out_of_range.unwrap_or(Policy::Fold) {
            Policy::Fold => OutOfRange::Fold,
            Policy::Drop => OutOfRange::Drop,
        },
        table,
        close: time(p, "close", &file.close, CLOSE)?,
        settle: time(p, "settle", &file.settle, SETTLE)?,
        voice: voice(p, file.voice.as_deref())?,
    };
    if wind.channels == ChannelMask(0) {
        return Err(RobotError::field(
            format!("{p}channels"),
            "none: the group would play nothing",
        ));
    }
    let air = time(p, "air", &file.air, AIR)?;
    let program = match file.program {
        Some(v) => int(&format!("{p}program"), v, 1, 128, "a General MIDI program")?,
        None => 75, // recorder
    };
    let notes: Vec<u8> = (range.low().get()..=range.high().get()).collect();
    let mut outputs = vec!["valve".to_string()];
    outputs.extend(fingers.iter().cloned());
    let mut group_notes = vec![notes];
    group_notes.resize(outputs.len(), Vec::new());
    Ok(Read {
        wind,
        group: Group {
            name: file.name.clone().unwrap_or_else(|| "wind".into()),
            kind: GroupKind::Fingered,
            first: first as u8,
            outputs,
            notes: group_notes,
            program: Some(program),
        },
        mechanics: mechanics(first, fingers.len(), air),
        sim: sim(&wind),
    })
}

/// The virtual robot's fingered group: what each fingering sounds and the breath it needs.
fn sim(wind: &Wind) -> WindMechanics {
    let table = (0..wind.range.keys() as u8)
        .map(|i| {
            let f = wind.fingering(i);
            Breath {
                fingers: f.fingers,
                note: wind.range.low().get() + i,
                breath: f.breath,
            }
        })
        .collect();
    WindMechanics {
        valve: wind.valve(),
        fingers: wind.fingers,
        table,
    }
}

/// The valve sounds `air` after it opens; a finger sounds nothing (its mechanics only time
/// it: on the virtual robot it closes its hole in 15 ms and lifts in 25 ms, the default key's
/// travel, so a `settle` shorter than 25 ms cracks notes there).
fn mechanics(first: usize, fingers: usize, air: Duration) -> Vec<(u8, KeyMechanics)> {
    let valve = KeyMechanics {
        press_delay: air,
        soft_press_delay: air,
        release_delay: Duration::from_millis(5),
        min_hold: Duration::from_millis(2),
        mute_after: None,
        ..KeyMechanics::DEFAULT
    };
    let finger = KeyMechanics {
        mute_after: None,
        ..KeyMechanics::DEFAULT
    };
    std::iter::once((first as u8, valve))
        .chain((0..fingers).map(|i| ((first + 1 + i) as u8, finger)))
        .collect()
}

fn time(p: &str, name: &str, text: &Option<String>, default: &str) -> Result<Duration, RobotError> {
    delay(&format!("{p}{name}"), text.as_deref().unwrap_or(default))
}

fn voice(p: &str, text: Option<&str>) -> Result<Voice, RobotError> {
    match text.unwrap_or("highest") {
        "highest" => Ok(Voice::Highest),
        "lowest" => Ok(Voice::Lowest),
        "last" => Ok(Voice::Last),
        other => Err(RobotError::field(
            format!("{p}voice"),
            format!("{other:?}: \"highest\" (the melody), \"lowest\" or \"last\""),
        )),
    }
}

/// The fingering table: every note from the lowest to the highest given, each once.
fn table(
    file: &FingeredFile,
    p: &str,
) -> Result<(KeyRange, [Fingering; orch_core::wind::MAX_FINGERINGS]), RobotError> {
    let mut by_note: Vec<(u8, Fingering)> = Vec::new();
    for (i, n) in file.note.iter().enumerate() {
        let q = format!("{p}note[{i}].");
        let note = int(&format!("{q}note"), n.note, 0, 127, "a MIDI note")?;
        if by_note.iter().any(|(m, _)| *m == note) {
            return Err(RobotError::field(
                format!("{q}note"),
                format!("note {note} is given twice"),
            ));
        }
        let mut mask = 0u16;
        for word in n.fingers.split_whitespace() {
            let Some(f) = file.fingers.iter().position(|name| name == word) else {
                return Err(RobotError::field(
                    format!("{q}fingers"),
                    format!("{word:?} is not one of fingered.fingers"),
                ));
            };
            mask |= 1 << f;
        }
        let breath = duty(&format!("{q}breath"), n.breath.as_deref().unwrap_or("100%"))?;
        if breath.get() == 0 {
            return Err(RobotError::field(
                format!("{q}breath"),
                "0%: the note would get no air",
            ));
        }
        by_note.push((
            note,
            Fingering {
                fingers: mask,
                breath: breath.get(),
            },
        ));
    }
    by_note.sort_by_key(|(n, _)| *n);
    let (Some(lo), Some(hi)) = (by_note.first(), by_note.last()) else {
        return Err(RobotError::field(
            format!("{p}note"),
            "no [[fingered.note]] tables: give each note's fingering",
        ));
    };
    let range = KeyRange::new(Note::from_bits(lo.0), Note::from_bits(hi.0)).expect("sorted");
    if range.keys() != by_note.len() || range.keys() > orch_core::wind::MAX_FINGERINGS {
        return Err(RobotError::field(
            format!("{p}note"),
            format!(
                "notes {}..={} with {} given: give every note between the lowest and the highest, at most {}",
                lo.0,
                hi.0,
                by_note.len(),
                orch_core::wind::MAX_FINGERINGS
            ),
        ));
    }
    let mut table = [Fingering::NONE; orch_core::wind::MAX_FINGERINGS];
    for (i, (_, f)) in by_note.into_iter().enumerate() {
        table[i] = f;
    }
    Ok((range, table))
}
