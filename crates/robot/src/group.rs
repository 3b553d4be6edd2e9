//! A robot's instruments as people name them: the keyboard, drum kits, glockenspiels.

use std::ops::Range;

use orch_core::{ChannelMask, KeyRange};

/// What kind of instrument a group is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GroupKind {
    /// Keys held down while their notes sound (`[keys]`).
    Keyboard,
    /// Unpitched strikes: a drum kit, its outputs named (`[[strike]]` with outputs).
    Kit,
    /// Pitched strikes: a glockenspiel, one output a note (`[[strike]]` with `low` and
    /// `high`).
    Pitched,
    /// A wind instrument (`[[fingered]]`): its valve (output 0, which every note lands on)
    /// and its fingers, one note at a time.
    Fingered,
}

impl GroupKind {
    /// Whether its outputs strike (a pulse that ends by itself) rather than hold.
    pub fn strikes(self) -> bool {
        matches!(self, GroupKind::Kit | GroupKind::Pitched)
    }
}

/// One instrument of a robot: its outputs (keys of the robot, in order from `first`), their
/// names and the notes each plays.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Group {
    /// The group's name (`[[strike]] name`; "keyboard" for the keys).
    pub name: String,
    /// What it is.
    pub kind: GroupKind,
    /// Its first output: a key of the robot (0 = the first output of the first board).
    pub first: u8,
    /// Each output's name: the note's name for keys and bars (`C4`), the drum's for a kit
    /// (`kick`).
    pub outputs: Vec<String>,
    /// The notes each output plays as written (folded notes aside).
    pub notes: Vec<Vec<u8>>,
    /// The General MIDI program (1..=128) a pitched group sounds as in `orch render`; `None`
    /// for a keyboard (the render's piano) and a kit (the GM drum kit).
    pub program: Option<u8>,
}

impl Group {
    /// The keyboard of `range`.
    pub(crate) fn keyboard(range: KeyRange, _channels: ChannelMask) -> Self {
        let (lo, hi) = (range.low().get(), range.high().get());
        Self {
            name: "keyboard".into(),
            kind: GroupKind::Keyboard,
            first: 0,
            outputs: (lo..=hi).map(note_name).collect(),
            notes: (lo..=hi).map(|n| vec![n]).collect(),
            program: None,
        }
    }

    /// Its keys.
    pub fn keys(&self) -> Range<u8> {
        self.first..self.first + self.outputs.len() as u8
    }

    /// The name of output `key` (a key of the robot), if it is this group's.
    pub fn output_name(&self, key: u8) -> Option<&str> {
        let i = key.checked_sub(self.first)? as usize;
        self.outputs.get(i).map(String::as_str)
    }
}

/// A note's name with its octave, C4 = 60: `C4`, `F#2`.
pub fn note_name(note: u8) -> String {
    const NAMES: [&str; 12] = [
        "C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B",
    ];
    format!("{}{}", NAMES[note as usize % 12], note as i32 / 12 - 1)
}

/// General MIDI Level 1's name of percussion note `note` (35..=81) on channel 10: `Acoustic
/// Snare` for 38.
pub fn gm_drum_name(note: u8) -> Option<&'static str> {
    const NAMES: [&str; 47] = [
        "Acoustic Bass Drum",
        "Bass Drum 1",
        "Side Stick",
        "Acoustic Snare",
        "Hand Clap",
        "Electric Snare",
        "Low Floor Tom",
        "Closed Hi-Hat",
        "High Floor Tom",
        "Pedal Hi-Hat",
        "Low Tom",
        "Open Hi-Hat",
        "Low-Mid Tom",
        "Hi-Mid Tom",
        "Crash Cymbal 1",
        "High Tom",
        "Ride Cymbal 1",
        "Chinese Cymbal",
        "Ride Bell",
        "Tambourine",
        "Splash Cymbal",
        "Cowbell",
        "Crash Cymbal 2",
        "Vibraslap",
        "Ride Cymbal 2",
        "Hi Bongo",
        "Low Bongo",
        "Mute Hi Conga",
        "Open Hi Conga",
        "Low Conga",
        "High Timbale",
        "Low Timbale",
        "High Agogo",
        "Low Agogo",
        "Cabasa",
        "Maracas",
        "Short Whistle",
        "Long Whistle",
        "Short Guiro",
        "Long Guiro",
        "Claves",
        "Hi Wood Block",
        "Low Wood Block",
        "Mute Cuica",
        "Open Cuica",
        "Mute Triangle",
        "Open Triangle",
    ];
    NAMES.get(note.checked_sub(35)? as usize).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_are_named_with_c4_at_60() {
        assert_eq!(note_name(60), "C4");
        assert_eq!(note_name(42), "F#2");
        assert_eq!(note_name(0), "C-1");
        assert_eq!(note_name(127), "G9");
    }

    #[test]
    fn gm_drums_are_named_from_35_to_81() {
        assert_eq!(gm_drum_name(35), Some("Acoustic Bass Drum"));
        assert_eq!(gm_drum_name(42), Some("Closed Hi-Hat"));
        assert_eq!(gm_drum_name(81), Some("Open Triangle"));
        assert_eq!(gm_drum_name(34), None);
        assert_eq!(gm_drum_name(82), None);
    }
}
