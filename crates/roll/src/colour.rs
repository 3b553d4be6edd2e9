//! Colours and words for outcomes, and note names.

use crate::model::Outcome;

/// Lateness at which a late note's colour is at its darkest, ms: listeners notice a delay
/// from about 20–30 ms.
pub const LATE_FULL_MS: f64 = 30.0;

const LATE_FROM: (f64, f64, f64) = (240.0, 180.0, 0.0); // amber, just over 1 ms late
const LATE_TO: (f64, f64, f64) = (178.0, 24.0, 43.0); // dark red, 30 ms late or more

/// The colour of an outcome (a late note's by how late: `late_ms`).
pub fn of(outcome: &Outcome, late_ms: Option<f64>) -> String {
    match outcome {
        Outcome::OnTime => "#2a9d55".into(),
        Outcome::Late => late(late_ms.unwrap_or(LATE_FULL_MS)),
        Outcome::Early => "#7b3fbf".into(),
        Outcome::Unison => "#2166ac".into(),
        Outcome::Joined => "#138a8a".into(),
        Outcome::Dropped(_) => "#6f6f6f".into(),
        Outcome::Unmatched => "#d6336c".into(),
        Outcome::Skipped => "#a8a8a8".into(),
    }
}

/// Amber (1 ms late) to dark red ([`LATE_FULL_MS`] or more), linearly.
pub fn late(ms: f64) -> String {
    let f = ((ms - 1.0) / (LATE_FULL_MS - 1.0)).clamp(0.0, 1.0);
    let mix = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        mix(LATE_FROM.0, LATE_TO.0),
        mix(LATE_FROM.1, LATE_TO.1),
        mix(LATE_FROM.2, LATE_TO.2)
    )
}

/// The legend's words for an outcome.
pub fn label(name: &str) -> &'static str {
    match name {
        "on_time" => "on time",
        "late" => "late",
        "early" => "early",
        "unison" => "unison",
        "joined" => "joined",
        "dropped" => "dropped",
        "unmatched" => "no sound",
        _ => "skipped",
    }
}

/// A drop's reason in words.
pub fn reason(r: &str) -> &'static str {
    match r {
        "channel" => "its channel is not one the robot plays",
        "range" => "outside the robot's keys",
        "power" => "over the power budget",
        "too_fast" => "a re-strike that could not sound within the late limit",
        "monophonic" => "a chord's note the one-voice group does not play",
        "percussion" => "a drum note on channel 10 that no group of the robot plays",
        "unmapped" => "a drum the kit has no output for",
        "too_soft" => "struck below the key's softest duty: no sound",
        "cracked" => "the valve opened before the fingers settled: the note cracked",
        "cancelled" => "a waiting re-strike cancelled by a reset or the watchdog",
        "stopped" => "the performance was stopped first",
        _ => "no reason given",
    }
}

const NAMES: [&str; 12] = [
    "C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B",
];

/// "C4" for 60.
pub fn note_name(note: u8) -> String {
    format!("{}{}", NAMES[note as usize % 12], note as i32 / 12 - 1)
}

/// A black key's note.
pub fn is_black(note: u8) -> bool {
    matches!(note % 12, 1 | 3 | 6 | 8 | 10)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_shades_from_amber_to_dark_red() {
        assert_eq!(late(1.0), "#f0b400");
        assert_eq!(late(LATE_FULL_MS), "#b2182b");
        assert_eq!(late(500.0), "#b2182b");
        assert_ne!(late(10.0), late(20.0));
    }

    #[test]
    fn note_names_c4_is_60() {
        assert_eq!(note_name(60), "C4");
        assert_eq!(note_name(36), "C2");
        assert_eq!(note_name(61), "C#4");
        assert_eq!(note_name(0), "C-1");
    }
}
