//! What the keys do, in time: strikes (with their loudness) and releases, from the virtual
//! robot's performance or from the score itself.
//!
//! ## Which data says what (the robot)
//!
//! - **When a key strikes, and how loud**: each [`Press`](orch_sim::Press) of the
//!   performance whose `sounded` is `Some`: the virtual robot's own time for the hammer
//!   reaching the string (the pin going high plus the key's press delay at the strike's
//!   duty), and `loudness`, exactly, on the MIDI velocity scale (1 at the key's softest
//!   duty, 127 at full power, linear in the duty: not rounded to whole steps; every on/off
//!   key strikes at 127). A press with `sounded: None`
//!   (too short to reach the string, or `too_soft` on a PWM key) makes no sound, and a note
//!   the interpreter dropped or joined to a key already down has no press of its own: so
//!   dropped, joined and too-soft notes are silent, and late ones sound late, exactly as the
//!   report says. These are the very times the report's onsets and the note-by-note account
//!   (`--notes`: `sounded_ms`, `sounded_velocity`) are made from.
//! - **When the sound stops**: the performance's key-up sound events
//!   ([`SoundKind::Up`](orch_sim::SoundKind)): the key fully up again (the pin going low plus
//!   the key's release delay, never before its key-down), when the damper falls. A re-strike
//!   that smeared (pressed again before the key came up: no key-up between) strikes the
//!   string again while it sounds.
//! - **Order**: the key-down and key-up events of
//!   [`Performance::sounds`](orch_sim::Performance), in the virtual robot's own order; each
//!   key-down takes the loudness of the key's sounding press at that time (the presses of a
//!   key paired with its key-downs in time order; their counts must agree). Sounds are kept
//!   only by a performance recorded with `orch_sim::Keep::Everything`.
//!
//! A key's MIDI note is the robot's lowest note plus the key's index. Times are taken from
//! the start of the song (its score time 0): `start_us` of the performance.
//!
//! ## The score
//!
//! Every Note-On of the file strikes its note at its time and velocity (all channels, at the
//! written pitch, nothing folded or dropped; pedals and other messages are not played); the
//! note's key is released when no Note-On holds it any more (a Note-On on a sounding note
//! strikes it again, as a piano with one string per note would).

use orch_seq::Song;
use orch_sim::{Loudness, Performance, SoundKind};

use crate::error::RenderError;

/// What happens to a key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// The hammer strikes the string, this loud (1..=127, MIDI velocity's scale, exactly).
    Strike {
        /// How loud.
        loudness: Loudness,
    },
    /// The damper falls: the key is fully up again.
    Release,
}

/// One thing a key does, at a time from the start of the song.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyEvent {
    /// When, in nanoseconds from the song's start (negative: before it).
    pub at_ns: i64,
    /// The MIDI note of the key.
    pub note: u8,
    /// Strike or release.
    pub action: Action,
}

impl KeyEvent {
    /// The sample this event falls on at `rate` Hz: its time rounded to the nearest sample
    /// (a time before the song's start falls on sample 0).
    pub fn sample(&self, rate: u32) -> u64 {
        sample_at(self.at_ns, rate)
    }
}

/// The sample nearest to `at_ns` at `rate` Hz (0 for times before the start).
pub fn sample_at(at_ns: i64, rate: u32) -> u64 {
    if at_ns <= 0 {
        return 0;
    }
    let scaled = at_ns as u128 * u128::from(rate);
    ((scaled + 500_000_000) / 1_000_000_000) as u64
}

/// The virtual robot's sounds: see the [module notes](self). `start_us` is the song's start
/// on the performance's clock (`orch_perform::Played::start_us`), `low_note` the MIDI note of
/// key 0 (the robot's `range.low()`).
pub fn from_performance(
    performance: &Performance,
    start_us: u64,
    low_note: u8,
) -> Result<Vec<KeyEvent>, RenderError> {
    let m = performance.summary.mechanics;
    let downs = performance
        .sounds
        .iter()
        .filter(|s| s.kind == SoundKind::Down)
        .count() as u64;
    if downs != m.clean_onsets + m.smeared_onsets {
        return Err(RenderError::SoundsNotKept);
    }
    // Each key's sounding presses, by the time they sounded (stable: press order at a tie).
    let keys = performance
        .presses
        .iter()
        .map(|p| p.key)
        .max()
        .map_or(0, |k| k as usize + 1);
    let mut loudness: Vec<Vec<(u64, Loudness)>> = vec![Vec::new(); keys];
    for p in &performance.presses {
        if let (Some(at), Some(v)) = (p.sounded, p.loudness) {
            loudness[p.key as usize].push((at.as_nanos(), v));
        }
    }
    for presses in &mut loudness {
        presses.sort_by_key(|&(at, _)| at);
        presses.reverse(); // popped from the back, earliest first
    }
    let origin = i128::from(start_us) * 1000;
    let mut events = Vec::with_capacity(performance.sounds.len());
    for s in &performance.sounds {
        let note = u16::from(low_note) + u16::from(s.key);
        let note = u8::try_from(note)
            .ok()
            .filter(|n| *n < 128)
            .ok_or_else(|| {
                RenderError::Inconsistent(format!("key {} is past MIDI note 127", s.key))
            })?;
        let at_ns = (i128::from(s.time.as_nanos()) - origin) as i64;
        let action = match s.kind {
            SoundKind::Up => Action::Release,
            SoundKind::Down => {
                let (at, strength) = loudness
                    .get_mut(s.key as usize)
                    .and_then(Vec::pop)
                    .ok_or_else(|| {
                        RenderError::Inconsistent(format!(
                            "key {} sounded at {} with no sounding press",
                            s.key, s.time
                        ))
                    })?;
                if at != s.time.as_nanos() {
                    return Err(RenderError::Inconsistent(format!(
                        "key {} sounded at {} where its press says {at} ns",
                        s.key, s.time
                    )));
                }
                Action::Strike { loudness: strength }
            }
        };
        events.push(KeyEvent {
            at_ns,
            note,
            action,
        });
    }
    if let Some(k) = loudness.iter().position(|l| !l.is_empty()) {
        return Err(RenderError::Inconsistent(format!(
            "key {k} has a sounding press with no key-down sound"
        )));
    }
    Ok(events)
}

/// The score itself: see the [module notes](self).
pub fn from_song(song: &Song) -> Vec<KeyEvent> {
    let mut held = [0u32; 128];
    let mut events = Vec::new();
    for e in song.events() {
        let at_ns = (e.time_us * 1000) as i64;
        if let Some((_, note, velocity)) = e.bytes.note_on() {
            let note = note & 0x7F;
            held[note as usize] += 1;
            events.push(KeyEvent {
                at_ns,
                note,
                action: Action::Strike {
                    loudness: Loudness::of_velocity(velocity),
                },
            });
        } else if let Some((_, note)) = e.bytes.note_off() {
            let note = note & 0x7F;
            let h = &mut held[note as usize];
            if *h > 0 {
                *h -= 1;
                if *h == 0 {
                    events.push(KeyEvent {
                        at_ns,
                        note,
                        action: Action::Release,
                    });
                }
            }
        }
    }
    // Notes the file never lets go of end with it.
    let end = (song.duration_us() * 1000) as i64;
    for (note, h) in held.iter().enumerate() {
        if *h > 0 {
            events.push(KeyEvent {
                at_ns: end,
                note: note as u8,
                action: Action::Release,
            });
        }
    }
    events
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_round_to_the_nearest_sample() {
        assert_eq!(sample_at(-5, 44_100), 0);
        assert_eq!(sample_at(1_000_000_000, 44_100), 44_100);
        // 11.3 µs is 0.498 of a sample at 44.1 kHz, 11.4 µs 0.503.
        assert_eq!(sample_at(11_300, 44_100), 0);
        assert_eq!(sample_at(11_400, 44_100), 1);
    }

    fn smf(track: &[u8]) -> Song {
        let mut b = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
        b.extend_from_slice(&(track.len() as u32 + 4).to_be_bytes());
        b.extend_from_slice(track);
        b.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
        Song::parse(&b).unwrap()
    }

    #[test]
    fn a_score_note_held_twice_is_struck_twice_and_released_by_the_last_note_off() {
        // 60 on (v 100), 60 on again (v 50) a quarter later, both off after another quarter,
        // the second off a quarter after the first. 480 ticks a quarter at 120 bpm: 500 ms.
        let song = smf(&[
            0x00, 0x90, 60, 100, 0x83, 0x60, 0x90, 60, 50, 0x83, 0x60, 0x80, 60, 0, 0x83, 0x60,
            0x80, 60, 0,
        ]);
        let e = from_song(&song);
        let ms = 1_000_000i64;
        assert_eq!(
            e,
            vec![
                KeyEvent {
                    at_ns: 0,
                    note: 60,
                    action: Action::Strike {
                        loudness: Loudness::of_velocity(100)
                    }
                },
                KeyEvent {
                    at_ns: 500 * ms,
                    note: 60,
                    action: Action::Strike {
                        loudness: Loudness::of_velocity(50)
                    }
                },
                KeyEvent {
                    at_ns: 1500 * ms,
                    note: 60,
                    action: Action::Release
                },
            ]
        );
    }
}
