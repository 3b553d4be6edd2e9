//! The strike outputs of a robot as the calibration score strikes them: each output of each
//! `[[strike]]` group, with a note and a channel that reach it.
//!
//! A kit's output is struck with the first of its notes that reaches it on the lowest of its
//! group's channels that does (a note goes to the first strike group that listens to its
//! channel and maps it); a pitched group's bar with its own note. An output no note reaches
//! (an earlier group takes all of them) is left out of the score.

use orch_core::{Channel, Note};
use orch_robot::{GroupKind, Robot};

/// One strike output of the robot.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Output {
    /// The robot's output (a key index: 0 is the first output of the first board).
    pub key: u8,
    /// The group's name (`[[strike]] name`).
    pub group: String,
    /// The group's index among the `[[strike]]` tables.
    pub strike: usize,
    /// Whether the group is a kit (its outputs have `[[strike.output]]` tables) or pitched.
    pub kind: GroupKind,
    /// Its index in its group (the `[[strike.output]]` table's, or the bar's from `low`).
    pub index: usize,
    /// The output's name (`kick`, `G5`).
    pub name: String,
    /// The channel it is struck on, 0..=15 (channel 10 is 9).
    pub channel: u8,
    /// The note it is struck with.
    pub note: u8,
}

/// Every strike output of `robot`, in key order.
pub fn strike_outputs(robot: &Robot) -> Vec<Output> {
    let strikes = &robot.config.strikes;
    let mut out = Vec::new();
    let groups = robot.groups.iter().filter(|g| g.kind.strikes());
    for (g, group) in groups.enumerate() {
        let Some(mask) = strikes.groups().get(g).map(|s| s.channels) else {
            continue;
        };
        for (i, notes) in group.notes.iter().enumerate() {
            let key = group.first + i as u8;
            let reaches = |c: u8, n: u8| {
                let ch = Channel::new(c).expect("0..=15");
                let note = Note::new(n).expect("a MIDI note");
                mask.contains(ch)
                    && matches!(strikes.find(ch, note), Some(Ok(of)) if of.key == key && of.octaves == 0)
            };
            let found = (0..16u8)
                .flat_map(|c| notes.iter().map(move |&n| (c, n)))
                .find(|&(c, n)| reaches(c, n));
            if let Some((channel, note)) = found {
                out.push(Output {
                    key,
                    group: group.name.clone(),
                    strike: g,
                    kind: group.kind,
                    index: i,
                    name: group.outputs[i].clone(),
                    channel,
                    note,
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_drum_kit_is_struck_on_channel_10_with_each_outputs_first_note() {
        let text = orch_robot::instrument_toml(
            orch_robot::Instrument::Drums,
            orch_robot::BoardKind::OnOff,
        );
        let robot = Robot::from_toml(&text).unwrap();
        let outs = strike_outputs(&robot);
        assert_eq!(outs.len(), 9);
        assert_eq!(outs[0].name, "kick");
        assert_eq!((outs[0].key, outs[0].channel, outs[0].note), (0, 9, 35));
        assert_eq!((outs[2].name.as_str(), outs[2].note), ("hi-hat", 42));
        assert!(outs.iter().all(|o| o.kind == GroupKind::Kit));
    }

    #[test]
    fn a_glockenspiel_is_struck_bar_by_bar_and_a_keyboard_has_none() {
        let text = orch_robot::instrument_toml(
            orch_robot::Instrument::Glockenspiel,
            orch_robot::BoardKind::Pwm,
        );
        let outs = strike_outputs(&Robot::from_toml(&text).unwrap());
        assert_eq!(outs.len(), 30);
        assert_eq!((outs[0].note, outs[29].note, outs[29].key), (79, 108, 29));
        assert!(strike_outputs(&Robot::thesis()).is_empty());
    }
}
