//! A [`Roll`] from a song and its performance on the virtual robot: the note-by-note account
//! ([`Played::account_indexed`]), each note's Note-Off ([`Song::note_spans`]), each strike's
//! sound and key-up (the virtual robot's presses and sound events), the bar lines
//! ([`Song::bar_start_us`]).

use std::fmt;

use orch_perform::Played;
use orch_seq::Song;
use orch_sim::SoundKind;

use crate::model::{BarLine, Outcome, Roll, RollNote, Strike};

/// Why a performance cannot be drawn.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BuildError {
    /// It jumped (a bar skipped or played again): performance time no longer follows the
    /// score's bars.
    Jumped,
    /// The virtual robot kept no sound events (`orch_sim::Keep::Presses`), so a strike's
    /// key-up is not known: perform with `Keep::Everything`.
    NoSounds,
    /// A line of the account names an outcome the roll does not know.
    UnknownOutcome(&'static str),
    /// The performance's notes are not the song's Note-Ons, one for one (it played only
    /// some of them: a robot given some channels), so a note's Note-Off is not known.
    NotTheSong,
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Jumped => write!(
                f,
                "the performance jumped: a roll is drawn from a performance played straight through"
            ),
            Self::NoSounds => write!(
                f,
                "the virtual robot kept no sound events (Keep::Everything is needed for the key-ups)"
            ),
            Self::UnknownOutcome(o) => write!(f, "unknown outcome {o:?} in the account"),
            Self::NotTheSong => write!(
                f,
                "the performance did not play the song's notes one for one (some channels only?)"
            ),
        }
    }
}

impl std::error::Error for BuildError {}

/// How one of the robot's outputs is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputRow {
    /// A key held while its note sounds, on its pitch's row.
    Key(u8),
    /// A bar struck (a glockenspiel's), on its pitch's row, drawn as hits.
    Bar(u8),
    /// A drum of a kit, on its named lane ([`Rows::lanes`]), drawn as hits.
    Drum(u16),
    /// A wind robot's valve, every note of its one voice landing on it: each drawn on the
    /// row of its written pitch, held.
    Voice,
    /// An output no note strikes itself (a lift, a damper, a finger): not drawn.
    None,
}

/// Where each of the robot's outputs is drawn: the pitch rows of its keys and bars, and the
/// named lanes of its drums.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Rows {
    /// The robot's lowest and highest pitch row, as MIDI notes (shaded as its keys);
    /// `None` for a robot with no keys or bars (a drum kit alone).
    pub keys: Option<(u8, u8)>,
    /// Each output's row, by output (key) index. Outputs past the list are keys from
    /// `keys.0` up.
    pub outputs: Vec<OutputRow>,
    /// The named lanes, top to bottom (a kit's drums).
    pub lanes: Vec<String>,
    /// The channels (bit 0 = channel 1) a kit listens to: a note on one of them that no
    /// output plays (a drum the kit lacks) is drawn on the last lane, "not in the kit",
    /// added for it.
    pub drum_channels: u16,
}

/// Where one note is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Place {
    /// The pitch row of the key or bar it landed on, if it is drawn on one.
    pub landed: Option<u8>,
    /// Its lane, if it is drawn on one.
    pub lane: Option<u16>,
    /// Struck, not held.
    pub hit: bool,
}

/// The lane a kit's note with no output of its own is drawn on.
pub const NOT_IN_THE_KIT: &str = "not in the kit";

impl Rows {
    /// A keyboard of the MIDI notes `keys.0..=keys.1`: output `k` is note `keys.0 + k`.
    pub fn keyboard(keys: (u8, u8)) -> Self {
        Self {
            keys: Some(keys),
            ..Self::default()
        }
    }

    /// Where a note written `written` on `channel` (1..=16) that landed on output `key`
    /// (`None`: on no output) is drawn.
    pub fn place(&self, key: Option<u8>, channel: u8, written: u8) -> Place {
        let pitch = |landed, hit| Place {
            landed: Some(landed),
            lane: None,
            hit,
        };
        let Some(key) = key else {
            let drum = channel >= 1 && self.drum_channels & (1 << (channel - 1)) != 0;
            return Place {
                landed: None,
                lane: drum.then_some(self.lanes.len() as u16),
                hit: drum,
            };
        };
        match self.outputs.get(key as usize) {
            Some(OutputRow::Key(note)) => pitch(*note, false),
            Some(OutputRow::Bar(note)) => pitch(*note, true),
            Some(OutputRow::Drum(lane)) => Place {
                landed: None,
                lane: Some(*lane),
                hit: true,
            },
            Some(OutputRow::None) => pitch(written, true),
            Some(OutputRow::Voice) => pitch(written, false),
            None => pitch(self.keys.map_or(0, |k| k.0).saturating_add(key), false),
        }
    }
}

/// The roll of `played`, a performance of `song` at tempo factor `tempo` (2: twice as
/// fast) on a robot whose keys are the MIDI notes `keys.0..=keys.1`, titled `title`.
pub fn roll(
    song: &Song,
    played: &Played,
    keys: (u8, u8),
    tempo: f64,
    title: &str,
) -> Result<Roll, BuildError> {
    roll_on(song, played, &Rows::keyboard(keys), tempo, title)
}

/// [`roll`] on a robot whose outputs are drawn on `rows` (strike groups beside or instead of
/// a keyboard).
pub fn roll_on(
    song: &Song,
    played: &Played,
    rows: &Rows,
    tempo: f64,
    title: &str,
) -> Result<Roll, BuildError> {
    if played.jumps > 0 || played.replayed > 0 {
        return Err(BuildError::Jumped);
    }
    let key_ups = played
        .performance
        .sounds
        .iter()
        .any(|e| e.kind == SoundKind::Up);
    let tempo = if tempo > 0.0 { tempo } else { 1.0 };
    // Song µs to performance ms.
    let wall_ms = |us: u64| us as f64 / tempo / 1000.0;
    let start = played.start_us as i64;
    let spans = song.note_spans();
    if spans.len() != played.records.len()
        || spans
            .iter()
            .zip(&played.records)
            .any(|(s, r)| (s.channel, s.note) != (r.channel, r.note))
    {
        return Err(BuildError::NotTheSong);
    }
    let keyups = KeyUps::of(played);
    // Record i is the song's note i (checked above): its bar is its own.
    let lines = played.account_indexed(|i, _| song.bar_beat(spans[i].on_us));
    let mut notes = Vec::with_capacity(lines.len());
    let mut end_ms = wall_ms(song.duration_us());
    for (i, line) in lines {
        let outcome = Outcome::from_account(line.outcome, line.reason)
            .ok_or(BuildError::UnknownOutcome(line.outcome))?;
        let length_ms = wall_ms(spans[i].off_us.saturating_sub(spans[i].on_us));
        let strike = match (line.sounded_ms, line.onset_ms, line.key) {
            (Some(_), Some(_), Some(_)) if !key_ups => return Err(BuildError::NoSounds),
            (Some(sounded_ms), Some(onset_ms), Some(key)) => {
                let sounded_us = (sounded_ms * 1000.0).round() as i64 + start;
                let up_us = keyups.after(key, sounded_us);
                let up_ms = ((up_us - start) as f64 / 1000.0).max(sounded_ms);
                end_ms = end_ms.max(up_ms);
                Some(Strike {
                    sounded_ms,
                    up_ms,
                    onset_ms,
                    velocity: line.sounded_velocity,
                })
            }
            _ => None,
        };
        let place = rows.place(line.key, line.channel, line.note);
        notes.push(RollNote {
            t_ms: line.t_ms,
            end_ms: line.t_ms + length_ms,
            bar: line.bar,
            beat: line.beat,
            note: line.note,
            channel: line.channel,
            velocity: line.velocity,
            landed: place.landed,
            outcome,
            strike,
            lane: place.lane,
            hit: place.hit,
        });
    }
    let mut lanes = rows.lanes.clone();
    if notes.iter().any(|n| n.lane == Some(lanes.len() as u16)) {
        lanes.push(NOT_IN_THE_KIT.to_string());
    }
    let pitched = rows.keys.is_some() || notes.iter().any(|n| n.lane.is_none());
    let keys = rows.keys.map(|(a, b)| (a.min(b), a.max(b)));
    // The drawing runs on to the line that closes the last bar.
    let last_bar = song.bar_beat(song.duration_us().saturating_sub(1)).0;
    if let Some(close) = song.bar_start_us(last_bar.saturating_add(1)) {
        end_ms = end_ms.max(wall_ms(close));
    }
    let bars = (1..=last_bar.saturating_add(1))
        .filter_map(|b| {
            song.bar_start_us(b).map(|us| BarLine {
                bar: b,
                t_ms: wall_ms(us),
            })
        })
        .filter(|b| b.t_ms <= end_ms)
        .collect();
    Ok(Roll {
        title: title.to_string(),
        notes,
        bars,
        end_ms,
        keys,
        dynamics: played.dynamic_keys.iter().any(|d| *d),
        lanes,
        pitched,
    })
}

/// Each key's key-up times, µs, ascending, and when its strikes sounded.
struct KeyUps {
    ups: Vec<Vec<i64>>,
    downs: Vec<Vec<i64>>,
    end: i64,
}

impl KeyUps {
    fn of(played: &Played) -> Self {
        let perf = &played.performance;
        let keys = perf
            .sounds
            .iter()
            .map(|e| usize::from(e.key) + 1)
            .max()
            .unwrap_or(0);
        let mut ups = vec![Vec::new(); keys];
        let mut downs = vec![Vec::new(); keys];
        for e in &perf.sounds {
            let t = (e.time.as_nanos() / 1000) as i64;
            match e.kind {
                SoundKind::Up => ups[usize::from(e.key)].push(t),
                SoundKind::Down => downs[usize::from(e.key)].push(t),
            }
        }
        for v in ups.iter_mut().chain(downs.iter_mut()) {
            v.sort_unstable();
        }
        Self {
            ups,
            downs,
            end: (perf.summary.end.as_nanos() / 1000) as i64,
        }
    }

    /// When `key`, sounded at `sounded_us`, was fully up again: its next key-up, or the next
    /// key-down if that comes first (a re-press before it was up), or the end.
    fn after(&self, key: u8, sounded_us: i64) -> i64 {
        let k = usize::from(key);
        let next = |v: Option<&Vec<i64>>| {
            v.and_then(|v| v.get(v.partition_point(|t| *t <= sounded_us)).copied())
        };
        let up = next(self.ups.get(k)).unwrap_or(self.end);
        next(self.downs.get(k)).map_or(up, |d| up.min(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two keys (C4, C#4), a bar (G5), a kit of kick and snare on channel 10, and a lift.
    fn rows() -> Rows {
        Rows {
            keys: Some((60, 61)),
            outputs: vec![
                OutputRow::Key(60),
                OutputRow::Key(61),
                OutputRow::Bar(79),
                OutputRow::Drum(1),
                OutputRow::Drum(0),
                OutputRow::None,
            ],
            lanes: vec!["snare".into(), "kick".into()],
            drum_channels: 1 << 9,
        }
    }

    #[test]
    fn keys_and_bars_go_on_their_pitch_and_drums_on_their_lanes() {
        let r = rows();
        let place = |key, channel, note| r.place(key, channel, note);
        assert_eq!(
            place(Some(1), 1, 73),
            Place {
                landed: Some(61),
                lane: None,
                hit: false
            }
        );
        assert_eq!(
            place(Some(2), 1, 67),
            Place {
                landed: Some(79),
                lane: None,
                hit: true
            }
        );
        assert_eq!(
            place(Some(3), 10, 36),
            Place {
                landed: None,
                lane: Some(1),
                hit: true
            }
        );
        // A drum the kit lacks: the lane after the kit's, "not in the kit".
        assert_eq!(
            place(None, 10, 81),
            Place {
                landed: None,
                lane: Some(2),
                hit: true
            }
        );
        // A note on no output elsewhere stays on its written pitch's row.
        assert_eq!(
            place(None, 1, 20),
            Place {
                landed: None,
                lane: None,
                hit: false
            }
        );
        // A keyboard alone: output k is note low + k.
        let keys = Rows::keyboard((36, 96));
        assert_eq!(keys.place(Some(24), 1, 60).landed, Some(60));
    }
}
