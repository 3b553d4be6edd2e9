//! The calibration score: the sync figure, then every key alone at each velocity level,
//! then every strike output (a drum, a bar) alone at each level.
//!
//! Times are in ms from the score's start; the SMF has 1000 ticks a quarter note at
//! 60 BPM, so one tick is one ms.

use crate::outputs::{strike_outputs, Output};
use crate::CalibrateError;

/// The sync figure's strike times, ms from the first: the marks of a Golomb ruler
/// (0, 1, 4, 9, 11) × 150 ms. Every interval between two strikes (150, 450, 600, 750, 900,
/// 1050, 1200, 1350, 1500, 1650 ms... each pair its own) occurs once, so the figure matches
/// itself at one shift only, and no part of the evenly spaced key strikes (1 s apart) can
/// pass for it.
pub const SYNC_MARKS_MS: [u32; 5] = [0, 150, 600, 1350, 1650];
/// When the first sync strike is asked, ms from the score's start: room for the performer to
/// send the first press on time.
pub const LEAD_IN_MS: u32 = 1000;
/// When the first key strike is asked: 2.35 s of silence after the figure's last strike, so
/// the figure ends, rings down and cannot blend into the strikes.
pub const FIRST_STRIKE_MS: u32 = LEAD_IN_MS + 4000;
/// From one key strike to the next. Longer than the longest press delay assumed (150 ms:
/// solenoid actions take 30 to over 100 ms when soft), the note (150 ms), the release (up
/// to 80 ms) and the damper's ring-down to the noise (about 500 ms), so each strike is heard
/// alone in its own window.
pub const SPACING_MS: u32 = 1000;
/// From one strike of a strike output to the next: a drum or a cymbal rings far longer than
/// a damped string (a crash for seconds), so each gets 3 s: a crash struck hard (its noise
/// decaying in 1–1.5 s) is 20 dB down by then, 14 dB at 2 s, where a ride struck after it
/// 12 dB softer went unheard. Listening counts only rises, and the noise frames before each
/// strike hold what still rings, so a tail is part of the noise, not a strike.
pub const STRIKE_SPACING_MS: u32 = 3000;
/// How long each strike's note is held: longer than `dynamics.strike` (40 ms) so the whole
/// strike phase plays, short enough that the damper stops the string well before the next.
pub const NOTE_MS: u32 = 150;
/// The velocity of the sync figure's strikes: full power, the loudest and quickest.
pub const SYNC_VELOCITY: u8 = 127;

/// What a strike is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// One of the sync figure's strikes (index in [`SYNC_MARKS_MS`]).
    Sync(usize),
    /// A key's strike at one of the levels.
    Key,
    /// A strike output's strike at one of the levels (index in [`Score::outputs`]).
    Strike(usize),
}

/// One strike the score asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strike {
    /// The MIDI note.
    pub note: u8,
    /// The channel, 0..=15 (0 for keys).
    pub channel: u8,
    /// The strike output struck (index in [`Score::outputs`]), `None` for a key.
    pub output: Option<usize>,
    /// Its velocity, 1..=127.
    pub velocity: u8,
    /// When it is asked, ms from the score's start.
    pub at_ms: u32,
    /// What it is for.
    pub part: Part,
}

/// The calibration score of a robot: its key range and the number of velocity levels.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Score {
    /// The lowest key's note.
    pub low: u8,
    /// The highest key's note.
    pub high: u8,
    /// The velocities each key is struck at, softest first.
    pub velocities: Vec<u8>,
    /// Whether the robot has a keyboard: without one the score strikes only its outputs.
    pub keyboard: bool,
    /// The strike outputs, struck after the keys at the same velocities.
    pub outputs: Vec<Output>,
}

impl Score {
    /// The score for keys `low..=high` at `levels` velocities spread evenly over 1..=127
    /// (1 level: 127 only).
    pub fn new(low: u8, high: u8, levels: u32) -> Result<Self, CalibrateError> {
        if !(1..=127).contains(&levels) {
            return Err(CalibrateError::Levels(levels));
        }
        let velocities = if levels == 1 {
            vec![127]
        } else {
            (0..levels)
                .map(|i| (1.0 + 126.0 * f64::from(i) / f64::from(levels - 1)).round() as u8)
                .collect()
        };
        Ok(Self {
            low: low.min(high),
            high: high.max(low),
            velocities,
            keyboard: true,
            outputs: Vec::new(),
        })
    }

    /// The score for a robot's keys (if it has a keyboard) and strike outputs.
    pub fn for_robot(robot: &orch_robot::Robot, levels: u32) -> Result<Self, CalibrateError> {
        let r = robot.config.range;
        let keyboard = robot
            .groups
            .iter()
            .any(|g| g.kind == orch_robot::GroupKind::Keyboard);
        Ok(Self {
            keyboard,
            outputs: strike_outputs(robot),
            ..Self::new(r.low().get(), r.high().get(), levels)?
        })
    }

    /// The keys struck: `low..=high`, none without a keyboard.
    #[allow(clippy::reversed_empty_ranges)] // empty on purpose: no keyboard, no keys
    pub fn keys(&self) -> std::ops::RangeInclusive<u8> {
        if self.keyboard {
            self.low..=self.high
        } else {
            1..=0
        }
    }

    /// The sync figure's notes, one per mark: three keys at a quarter, a half and three
    /// quarters of the range, never the same key twice in a row.
    pub fn sync_notes(&self) -> [u8; 5] {
        let span = u32::from(self.high - self.low);
        let at = |num: u32| self.low + ((span * num + 2) / 4) as u8;
        let (a, b, c) = (at(1), at(2), at(3));
        [b, a, c, b, a]
    }

    /// The sync figure's strikes as (channel, note, output): on the keys ([`sync_notes`](
    /// Self::sync_notes)), or without a keyboard on three strike outputs at a quarter, a half
    /// and three quarters of their list.
    pub fn sync_targets(&self) -> [(u8, u8, Option<usize>); 5] {
        if self.keyboard || self.outputs.is_empty() {
            return self.sync_notes().map(|n| (0, n, None));
        }
        let n = self.outputs.len();
        let at = |num: usize| {
            let i = (n * num / 4).min(n - 1);
            let o = &self.outputs[i];
            (o.channel, o.note, Some(i))
        };
        let (a, b, c) = (at(1), at(2), at(3));
        [b, a, c, b, a]
    }

    /// Every strike, in time order: the figure, then each key from the lowest, its levels
    /// softest first (a strike then follows a softer one of its own key, or a neighbour's),
    /// then the strike outputs level by level, softest first, each level on every output
    /// in key order, [`STRIKE_SPACING_MS`] apart: a soft hit never follows a loud cymbal's
    /// tail.
    pub fn schedule(&self) -> Vec<Strike> {
        let mut out: Vec<Strike> = self
            .sync_targets()
            .iter()
            .zip(SYNC_MARKS_MS)
            .enumerate()
            .map(|(i, (&(channel, note, output), mark))| Strike {
                note,
                channel,
                output,
                velocity: SYNC_VELOCITY,
                at_ms: LEAD_IN_MS + mark,
                part: Part::Sync(i),
            })
            .collect();
        let mut at = FIRST_STRIKE_MS;
        for note in self.keys() {
            for &velocity in &self.velocities {
                out.push(Strike {
                    note,
                    channel: 0,
                    output: None,
                    velocity,
                    at_ms: at,
                    part: Part::Key,
                });
                at += SPACING_MS;
            }
        }
        for &velocity in &self.velocities {
            for (i, o) in self.outputs.iter().enumerate() {
                out.push(Strike {
                    note: o.note,
                    channel: o.channel,
                    output: Some(i),
                    velocity,
                    at_ms: at,
                    part: Part::Strike(i),
                });
                at += STRIKE_SPACING_MS;
            }
        }
        out
    }

    /// The score's length, ms: the last strike plus one spacing for it to ring down.
    pub fn length_ms(&self) -> u32 {
        let last = self.schedule().last().copied();
        let ring = match last.map(|s| s.part) {
            Some(Part::Strike(_)) => STRIKE_SPACING_MS,
            _ => SPACING_MS,
        };
        last.map_or(0, |s| s.at_ms) + ring
    }

    /// The length from the first sync strike to the end, ms: what a recording must hold.
    pub fn needed_ms(&self) -> u32 {
        self.length_ms() - LEAD_IN_MS
    }

    /// The score as a Standard MIDI File (format 0, 1 tick = 1 ms): keys on channel 1, each
    /// strike output on its own channel.
    pub fn to_smf(&self) -> Vec<u8> {
        use midly::num::{u15, u24, u28, u4, u7};
        use midly::{
            Format, Header, MetaMessage, MidiMessage, Smf, Timing, TrackEvent, TrackEventKind,
        };
        // (time, is_on, note, velocity, channel): Note-Offs before Note-Ons at the same time.
        let mut events: Vec<(u32, bool, u8, u8, u8)> = Vec::new();
        for s in self.schedule() {
            events.push((s.at_ms, true, s.note, s.velocity, s.channel));
            events.push((s.at_ms + NOTE_MS, false, s.note, 0, s.channel));
        }
        events.sort_by_key(|&(t, on, note, _, channel)| (t, on, note, channel));
        let mut track = vec![
            TrackEvent {
                delta: u28::new(0),
                kind: TrackEventKind::Meta(MetaMessage::TrackName(b"orch calibration score")),
            },
            TrackEvent {
                delta: u28::new(0),
                kind: TrackEventKind::Meta(MetaMessage::Tempo(u24::new(1_000_000))),
            },
        ];
        let mut last = 0;
        for (t, on, note, velocity, channel) in events {
            let message = if on {
                MidiMessage::NoteOn {
                    key: u7::new(note),
                    vel: u7::new(velocity),
                }
            } else {
                MidiMessage::NoteOff {
                    key: u7::new(note),
                    vel: u7::new(64),
                }
            };
            track.push(TrackEvent {
                delta: u28::new(t - last),
                kind: TrackEventKind::Midi {
                    channel: u4::new(channel),
                    message,
                },
            });
            last = t;
        }
        track.push(TrackEvent {
            delta: u28::new(0),
            kind: TrackEventKind::Meta(MetaMessage::EndOfTrack),
        });
        let smf = Smf {
            header: Header::new(Format::SingleTrack, Timing::Metrical(u15::new(1000))),
            tracks: vec![track],
        };
        let mut bytes = Vec::new();
        smf.write_std(&mut bytes)
            .expect("writing to a Vec does not fail");
        bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_spread_over_the_velocity_range() {
        assert_eq!(Score::new(36, 96, 4).unwrap().velocities, [1, 43, 85, 127]);
        assert_eq!(Score::new(36, 96, 1).unwrap().velocities, [127]);
        assert_eq!(Score::new(36, 96, 2).unwrap().velocities, [1, 127]);
        assert!(Score::new(36, 96, 0).is_err());
        assert!(Score::new(36, 96, 128).is_err());
    }

    #[test]
    fn sync_figure_intervals_are_all_different() {
        let mut d = Vec::new();
        for (i, a) in SYNC_MARKS_MS.iter().enumerate() {
            for b in &SYNC_MARKS_MS[i + 1..] {
                d.push(b - a);
            }
        }
        let n = d.len();
        d.sort();
        d.dedup();
        assert_eq!(d.len(), n, "a repeated interval: {d:?}");
        assert!(d.iter().all(|x| x % SPACING_MS != 0));
    }

    #[test]
    fn schedule_strikes_every_key_alone_at_every_level() {
        let s = Score::new(36, 96, 4).unwrap();
        let sched = s.schedule();
        assert_eq!(sched.len(), 5 + 61 * 4);
        let keys: Vec<_> = sched.iter().filter(|x| x.part == Part::Key).collect();
        assert!(keys
            .windows(2)
            .all(|w| w[1].at_ms - w[0].at_ms == SPACING_MS));
        assert!(sched[4].at_ms + 2000 < keys[0].at_ms);
        let notes = s.sync_notes();
        assert!(notes.windows(2).all(|w| w[0] != w[1]));
        assert!(notes.iter().all(|n| (36..=96).contains(n)));
        // 61 keys at 4 levels: 4 min 9 s.
        assert_eq!(s.length_ms(), 5000 + 244 * 1000);
    }

    #[test]
    fn strike_outputs_follow_the_keys_and_a_kit_alone_syncs_on_its_outputs() {
        let drums =
            orch_robot::instrument_toml(orch_robot::Instrument::Drums, orch_robot::BoardKind::Pwm);
        let robot = orch_robot::Robot::from_toml(&drums).unwrap();
        let s = Score::for_robot(&robot, 4).unwrap();
        assert!(!s.keyboard);
        let sched = s.schedule();
        assert_eq!(sched.len(), 5 + 9 * 4);
        assert!(sched[..5]
            .iter()
            .all(|x| x.channel == 9 && x.output.is_some()));
        let hits: Vec<_> = sched[5..].iter().collect();
        assert!(hits
            .windows(2)
            .all(|w| w[1].at_ms - w[0].at_ms == STRIKE_SPACING_MS));
        assert_eq!(
            (hits[0].part, hits[1].part),
            (Part::Strike(0), Part::Strike(1))
        );
        assert_eq!((hits[0].note, hits[35].note), (35, 51));
        assert_eq!((hits[0].velocity, hits[9].velocity), (1, 43));
        assert_eq!(s.length_ms(), FIRST_STRIKE_MS + 36 * STRIKE_SPACING_MS);
        // A keyboard robot's score is unchanged.
        let piano = Score::for_robot(&orch_robot::Robot::thesis(), 4).unwrap();
        assert_eq!(piano, Score::new(36, 96, 4).unwrap());
    }

    #[test]
    fn smf_holds_the_schedule() {
        let s = Score::new(60, 62, 2).unwrap();
        let bytes = s.to_smf();
        let smf = midly::Smf::parse(&bytes).unwrap();
        let mut t = 0;
        let mut ons = Vec::new();
        for e in &smf.tracks[0] {
            t += e.delta.as_int();
            if let midly::TrackEventKind::Midi {
                message: midly::MidiMessage::NoteOn { key, vel },
                ..
            } = e.kind
            {
                ons.push((t, key.as_int(), vel.as_int()));
            }
        }
        let want: Vec<_> = s
            .schedule()
            .iter()
            .map(|x| (x.at_ms, x.note, x.velocity))
            .collect();
        assert_eq!(ons, want);
    }
}
