//! What the keys do, in time: strikes (with their loudness and their sound) and releases,
//! from the virtual robot's performance or from the score itself.
//!
//! ## What each output sounds as
//!
//! A robot's outputs ("keys") are described by an [`Output`] each: the [`Instrument`] it
//! plays through the soundfont, its own note, and whether it rings on after its pulse. The
//! front end makes them from the robot's groups:
//!
//! - a **keyboard** key: the piano ([`Instrument::PIANO`], General MIDI program 1) at the
//!   key's note, sounding until the key is up again (the damper falls);
//! - a **drum kit**'s output: the soundfont's General MIDI drum kit (bank 128, what MIDI
//!   channel 10 plays), each strike sounding **the note the score asked for** (42, a closed
//!   hi-hat, and 46, an open one, on the same hi-hat output; given by [`StrikeNote`]s, the
//!   performance's account of which note each strike was), the output's first note where the
//!   account has none;
//! - a **pitched strike group**'s bar: its General MIDI program (a glockenspiel: program 10
//!   as people count, [`Instrument::Program`]`(9)`) at the bar's own note, so a folded note
//!   sounds where it landed.
//!
//! ## How long a strike rings
//!
//! A strike output's pulse ends by itself after a few ms, but the drum or bar it hit is not
//! damped: the virtual robot's key-up is not a release for it. Its voice is left to the
//! soundfont's own decay (a sampled drum or bar dies away by itself: on TimGM6mb a kick in
//! 80 ms, a closed hi-hat in 70 ms, a tom in 1.3 to 2.1 s, an open hi-hat in 2.5 s, a crash
//! in 4.2 to 4.6 s, a glockenspiel's G5 in 4.7 s, its C8 in 1.6 s), and is released (a
//! Note-Off: the font's release) only
//!
//! - when **its output strikes again** (one drum, one bar: the new strike takes over its
//!   vibration, as a key's re-strike does a string's), or
//! - when its beater **rests on it** too long (the virtual robot's
//!   [`Press::muted`](orch_sim::Press): powered against the head or bar past its contact
//!   time): at that moment, the strike plus its `mute_after`, as a damper would, or
//! - when **its damper** strikes (a damper output of the robot), or
//! - [`RING_NS`] (8 s) after its strike, which no drum or bar of TimGM6mb outlasts: only a
//!   font whose strikes sustain (a looped sample held at a level) is cut there, instead of
//!   piling up voices and ringing to the end of the render.
//!
//! General MIDI lets a receiver ignore Note-Offs on channel 10, and TimGM6mb's drums and
//! glockenspiel barely change with one (their release is about as long as their decay): so
//! on that font a strike sounds the same whenever its Note-Off comes, and these two rules
//! matter on fonts with short releases. What does cut a drum short is the soundfont's
//! exclusive classes, as a synthesizer plays them: a closed or pedal hi-hat (42, 44) ends an
//! open one's (46) sound at its strike, whichever outputs they are on (see
//! `crate::exclusive`, done across the render's synthesizers in [`crate::synth`]).

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
//! - **When the sound stops** (keyboard keys): the performance's key-up sound events
//!   ([`SoundKind::Up`](orch_sim::SoundKind)): the key fully up again (the pin going low plus
//!   the key's release delay, never before its key-down), when the damper falls. A re-strike
//!   that smeared (pressed again before the key came up: no key-up between) strikes the
//!   string again while it sounds. Strike outputs: see above.
//! - **Which note a drum strike sounds**: the [`StrikeNote`] of its key whose sound time,
//!   in whole µs, is the strike's (the performance's account: `orch_perform`'s records, each
//!   struck note's landing key and its sound time).
//! - **Order**: the key-down and key-up events of
//!   [`Performance::sounds`](orch_sim::Performance), in the virtual robot's own order; each
//!   key-down takes the loudness of the key's sounding press at that time (the presses of a
//!   key paired with its key-downs in time order; their counts must agree). Sounds are kept
//!   only by a performance recorded with `orch_sim::Keep::Everything`.
//!
//! Times are taken from the start of the song (its score time 0): `start_us` of the
//! performance.
//!
//! ## The score
//!
//! Every Note-On of the file strikes its note at its time and velocity (all channels, at the
//! written pitch, nothing folded or dropped; pedals and other messages are not played):
//! channel 10's on the General MIDI drum kit, ringing on as a kit's strikes do (its Note-Offs
//! are not releases: General MIDI's drums), every other channel's on the piano, the note's key
//! released when no Note-On holds it any more (a Note-On on a sounding note strikes it again,
//! as a piano with one string per note would). Program changes are not followed.

use std::collections::HashMap;

use orch_seq::Song;
use orch_sim::{Loudness, Performance, SoundKind};

use crate::error::RenderError;

/// How long a strike that rings on may ring at the most before its Note-Off: 8 s. See the
/// [module notes](self).
pub const RING_NS: i64 = 8_000_000_000;

/// The MIDI channel (0-based) General MIDI plays drums on: channel 10 as people count.
pub const DRUM_CHANNEL: u8 = 9;

/// What a strike sounds as in the soundfont.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Instrument {
    /// A melodic General MIDI program, 0-based (0: Acoustic Grand Piano; 9: Glockenspiel),
    /// in bank 0.
    Program(u8),
    /// The General MIDI drum kit: bank 128, program 0 (the standard kit), what MIDI
    /// channel 10 plays; a note is a drum (36 a bass drum, 42 a closed hi-hat).
    Drums,
}

impl Instrument {
    /// The piano every keyboard key plays: program 0, Acoustic Grand Piano.
    pub const PIANO: Instrument = Instrument::Program(0);

    /// The melodic instrument of General MIDI program `program` as people count it
    /// (1..=128: 10 is the glockenspiel); `None` outside that.
    pub fn gm_program(program: u8) -> Option<Instrument> {
        (1..=128)
            .contains(&program)
            .then(|| Instrument::Program(program - 1))
    }

    /// The soundfont bank and the program (0-based) it plays from.
    pub fn bank_and_program(self) -> (u8, u8) {
        match self {
            Instrument::Program(p) => (0, p & 0x7F),
            Instrument::Drums => (128, 0),
        }
    }
}

/// What happens to a key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// The hammer strikes the string, this loud (1..=127, MIDI velocity's scale, exactly).
    Strike {
        /// How loud.
        loudness: Loudness,
    },
    /// The damper falls: the key is fully up again (for a strike that rings on: its ring
    /// ends, see the [module notes](self)).
    Release,
}

/// One thing a key does, at a time from the start of the song.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyEvent {
    /// When, in nanoseconds from the song's start (negative: before it).
    pub at_ns: i64,
    /// The MIDI note it sounds (a drum's note for [`Instrument::Drums`]).
    pub note: u8,
    /// What it sounds as. A release ends the sound of the same instrument and note.
    pub instrument: Instrument,
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

/// What one output of the robot sounds as: see the [module notes](self).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output {
    /// The instrument.
    pub instrument: Instrument,
    /// Its note: a key's or a bar's pitch; for a drum, the note it sounds when the account
    /// does not say which of its notes a strike was.
    pub note: u8,
    /// Whether it rings on after its pulse (a strike output), rather than sounding until the
    /// key is up again (a keyboard key).
    pub rings: bool,
    /// Whether it makes no sound of its own (a lead, such as an open hi-hat's lift; a damper).
    pub silent: bool,
    /// The output it damps (a damper: its strike ends that output's ring).
    pub damps: Option<u8>,
    /// Whether each press sounds the note the account says (a wind robot's valve, on which
    /// every note of its voice lands), not `note`.
    pub by_account: bool,
}

impl Output {
    /// An output that sounds nothing: an open hi-hat's lift (its opening is in the note the
    /// stick then sounds, 46).
    pub fn silent() -> Self {
        Self {
            silent: true,
            ..Self::key(0)
        }
    }

    /// A wind robot's valve sounding as `instrument`: each press the note the account says
    /// (`note` where it says none), held until the valve closes.
    pub fn voice(instrument: Instrument, note: u8) -> Self {
        Self {
            instrument,
            by_account: true,
            ..Self::key(note)
        }
    }

    /// The damper of output `bar`: its strike ends that output's ring.
    pub fn damper(bar: u8) -> Self {
        Self {
            damps: Some(bar),
            ..Self::silent()
        }
    }

    /// A keyboard key playing `note` on the piano.
    pub fn key(note: u8) -> Self {
        Self {
            instrument: Instrument::PIANO,
            note,
            rings: false,
            silent: false,
            damps: None,
            by_account: false,
        }
    }

    /// A drum-kit output: the GM drum kit, `note` when the account says nothing.
    pub fn drum(note: u8) -> Self {
        Self {
            instrument: Instrument::Drums,
            note,
            rings: true,
            silent: false,
            damps: None,
            by_account: false,
        }
    }

    /// A bar of a pitched strike group sounding as `instrument` at `note`.
    pub fn bar(instrument: Instrument, note: u8) -> Self {
        Self {
            instrument,
            note,
            rings: true,
            silent: false,
            damps: None,
            by_account: false,
        }
    }
}

/// `keys` keyboard keys from `low_note` up (key 0 at `low_note`), as many as MIDI has notes
/// for.
pub fn keyboard(low_note: u8, keys: usize) -> Vec<Output> {
    (usize::from(low_note)..128)
        .take(keys)
        .map(|n| Output::key(n as u8))
        .collect()
}

/// The note a strike of a key sounded for, from the performance's account: the note as
/// written (`note`), the key it landed on and when its strike sounded, in whole µs on the
/// performance's clock (the sound's time in ns, divided by 1000 and rounded down: as the
/// account computes a note's onset).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StrikeNote {
    /// The key (output) that struck.
    pub key: u8,
    /// When its strike sounded, µs on the performance's clock.
    pub sounded_us: u64,
    /// The note as the score wrote it.
    pub note: u8,
}

/// The virtual robot's sounds on a keyboard alone: see the [module notes](self).
/// `start_us` is the song's start on the performance's clock (`orch_perform::Played::start_us`),
/// `low_note` the MIDI note of key 0 (the robot's `range.low()`).
pub fn from_performance(
    performance: &Performance,
    start_us: u64,
    low_note: u8,
) -> Result<Vec<KeyEvent>, RenderError> {
    let keys = performance
        .sounds
        .iter()
        .map(|s| usize::from(s.key) + 1)
        .max()
        .unwrap_or(0);
    if keys > 128 - usize::from(low_note) {
        return Err(RenderError::Inconsistent(format!(
            "key {} is past MIDI note 127",
            keys - 1
        )));
    }
    from_robot(performance, start_us, &keyboard(low_note, keys), &[])
}

/// The virtual robot's sounds, each key sounding as `outputs` says (key `k` as
/// `outputs[k]`), a drum strike at the note `written` gives it: see the [module
/// notes](self). `start_us` is the song's start on the performance's clock
/// (`orch_perform::Played::start_us`).
pub fn from_robot(
    performance: &Performance,
    start_us: u64,
    outputs: &[Output],
    written: &[StrikeNote],
) -> Result<Vec<KeyEvent>, RenderError> {
    let mut loudness = sounding_presses(performance)?;
    let written: HashMap<(u8, u64), u8> = written
        .iter()
        .map(|w| ((w.key, w.sounded_us), w.note))
        .collect();
    let origin = i128::from(start_us) * 1000;
    let mut events = Vec::with_capacity(performance.sounds.len());
    let mut rings = Rings::new(outputs.len());
    let mut voiced: HashMap<u8, u8> = HashMap::new();
    for s in &performance.sounds {
        let output = outputs.get(usize::from(s.key)).ok_or_else(|| {
            RenderError::Inconsistent(format!("key {} is not one of the robot's", s.key))
        })?;
        let at_ns = (i128::from(s.time.as_nanos()) - origin) as i64;
        let strike = match s.kind {
            SoundKind::Up if output.rings => continue,
            SoundKind::Up => None,
            SoundKind::Down => {
                let (at, strength, choked) = loudness
                    .get_mut(usize::from(s.key))
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
                Some((strength, choked))
            }
        };
        let choked = strike.and_then(|(_, choked)| choked);
        let strike = strike.map(|(strength, _)| strength);
        if output.silent {
            // A lift sounds nothing of its own; a damper's strike ends its bar's ring.
            if let (Some(bar), Some(_)) = (output.damps, strike) {
                rings.damp(usize::from(bar), at_ns, &mut events);
            }
            continue;
        }
        let note = if output.instrument == Instrument::Drums || output.by_account {
            let at = (s.key, s.time.as_nanos() / 1000);
            match (strike, output.by_account) {
                // A voice's key-up releases the note its key-down struck.
                (None, true) => voiced.get(&s.key).copied().unwrap_or(output.note),
                _ => written.get(&at).copied().unwrap_or(output.note),
            }
        } else {
            output.note
        };
        if output.by_account && strike.is_some() {
            voiced.insert(s.key, note);
        }
        let event = KeyEvent {
            at_ns,
            note: note & 0x7F,
            instrument: output.instrument,
            action: strike.map_or(Action::Release, |loudness| Action::Strike { loudness }),
        };
        if output.rings {
            rings.strike(usize::from(s.key), event, &mut events);
            // A beater that rested on its head or bar choked it (the virtual robot's `muted`).
            if let Some(choked) = choked {
                let choked_ns = (i128::from(choked) - origin) as i64;
                rings.damp(usize::from(s.key), choked_ns, &mut events);
            }
        } else {
            events.push(event);
        }
    }
    if let Some(k) = loudness.iter().position(|l| !l.is_empty()) {
        return Err(RenderError::Inconsistent(format!(
            "key {k} has a sounding press with no key-down sound"
        )));
    }
    rings.finish(&mut events);
    events.sort_by_key(|e| e.at_ns); // stable: a release before a strike at its time
    Ok(events)
}

/// A sounding press: when it sounded (ns), how loud, and when a beater resting on its head or
/// bar choked it (ns), if one did.
type Sounding = (u64, Loudness, Option<u64>);

/// Each key's sounding presses, the earliest last (popped from the back).
fn sounding_presses(performance: &Performance) -> Result<Vec<Vec<Sounding>>, RenderError> {
    let m = performance.summary.mechanics;
    let downs = performance
        .sounds
        .iter()
        .filter(|s| s.kind == SoundKind::Down)
        .count() as u64;
    if downs != m.clean_onsets + m.smeared_onsets {
        return Err(RenderError::SoundsNotKept);
    }
    let keys = performance
        .presses
        .iter()
        .map(|p| p.key)
        .max()
        .map_or(0, |k| k as usize + 1);
    let mut loudness: Vec<Vec<Sounding>> = vec![Vec::new(); keys];
    for p in &performance.presses {
        if let (Some(at), Some(v)) = (p.sounded, p.loudness) {
            let choked = p.muted.map(|c| c.as_nanos());
            loudness[p.key as usize].push((at.as_nanos(), v, choked));
        }
    }
    for presses in &mut loudness {
        // By the time they sounded (stable: press order at a tie), earliest last.
        presses.sort_by_key(|&(at, _, _)| at);
        presses.reverse();
    }
    Ok(loudness)
}

/// Strikes that ring on, each output's (or, for the score, each drum note's) last: their
/// releases, by the rules of the [module notes](self).
struct Rings {
    last: Vec<Option<KeyEvent>>,
}

impl Rings {
    fn new(outputs: usize) -> Self {
        Self {
            last: vec![None; outputs],
        }
    }

    /// Output `id` strikes (`event`): the release of its last strike, if that is due, then the
    /// strike, onto `events`.
    fn strike(&mut self, id: usize, event: KeyEvent, events: &mut Vec<KeyEvent>) {
        if let Some(last) = self.last[id].take() {
            let ring_end = last.at_ns.saturating_add(RING_NS);
            let same = (last.instrument, last.note) == (event.instrument, event.note);
            if ring_end <= event.at_ns {
                events.push(release(&last, ring_end));
            } else if !same {
                events.push(release(&last, event.at_ns));
            } // the same note struck again ends its own sound (see crate::synth)
        }
        self.last[id] = Some(event);
        events.push(event);
    }

    /// Output `id` is damped at `at_ns`: its strike still ringing then is released there.
    fn damp(&mut self, id: usize, at_ns: i64, events: &mut Vec<KeyEvent>) {
        let Some(slot) = self.last.get_mut(id) else {
            return;
        };
        if let Some(last) = slot.take_if(|l| l.at_ns < at_ns) {
            let end = at_ns.min(last.at_ns.saturating_add(RING_NS));
            events.push(release(&last, end));
        }
    }

    /// The releases of the strikes still ringing, [`RING_NS`] after each.
    fn finish(self, events: &mut Vec<KeyEvent>) {
        for last in self.last.into_iter().flatten() {
            events.push(release(&last, last.at_ns.saturating_add(RING_NS)));
        }
    }
}

/// The release of `strike`'s sound at `at_ns`.
fn release(strike: &KeyEvent, at_ns: i64) -> KeyEvent {
    KeyEvent {
        at_ns,
        action: Action::Release,
        ..*strike
    }
}

/// The score itself: see the [module notes](self).
pub fn from_song(song: &Song) -> Vec<KeyEvent> {
    let mut held = [0u32; 128];
    let mut events = Vec::new();
    let mut rings = Rings::new(128);
    for e in song.events() {
        let at_ns = (e.time_us * 1000) as i64;
        if let Some((channel, note, velocity)) = e.bytes.note_on() {
            let note = note & 0x7F;
            let strike = Action::Strike {
                loudness: Loudness::of_velocity(velocity),
            };
            if channel == DRUM_CHANNEL {
                let event = KeyEvent {
                    at_ns,
                    note,
                    instrument: Instrument::Drums,
                    action: strike,
                };
                rings.strike(usize::from(note), event, &mut events);
                continue;
            }
            held[note as usize] += 1;
            events.push(KeyEvent {
                at_ns,
                note,
                instrument: Instrument::PIANO,
                action: strike,
            });
        } else if let Some((channel, note)) = e.bytes.note_off() {
            let note = note & 0x7F;
            let h = &mut held[note as usize];
            if channel != DRUM_CHANNEL && *h > 0 {
                *h -= 1;
                if *h == 0 {
                    events.push(KeyEvent {
                        at_ns,
                        note,
                        instrument: Instrument::PIANO,
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
                instrument: Instrument::PIANO,
                action: Action::Release,
            });
        }
    }
    rings.finish(&mut events);
    events.sort_by_key(|e| e.at_ns);
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
                    instrument: Instrument::PIANO,
                    action: Action::Strike {
                        loudness: Loudness::of_velocity(100)
                    }
                },
                KeyEvent {
                    at_ns: 500 * ms,
                    note: 60,
                    instrument: Instrument::PIANO,
                    action: Action::Strike {
                        loudness: Loudness::of_velocity(50)
                    }
                },
                KeyEvent {
                    at_ns: 1500 * ms,
                    note: 60,
                    instrument: Instrument::PIANO,
                    action: Action::Release
                },
            ]
        );
    }

    fn strike(at_ms: i64, note: u8) -> KeyEvent {
        KeyEvent {
            at_ns: at_ms * 1_000_000,
            note,
            instrument: Instrument::Drums,
            action: Action::Strike {
                loudness: Loudness::of_velocity(100),
            },
        }
    }

    fn released(at_ms: i64, note: u8) -> KeyEvent {
        KeyEvent {
            action: Action::Release,
            ..strike(at_ms, note)
        }
    }

    #[test]
    fn a_damper_ends_its_outputs_ring_and_nothing_before_its_strike() {
        let mut events = Vec::new();
        let mut rings = Rings::new(2);
        rings.strike(0, strike(0, 79), &mut events);
        // Damped at 300 ms: released there; damped again: nothing rings any more.
        rings.damp(0, 300 * 1_000_000, &mut events);
        rings.damp(0, 400 * 1_000_000, &mut events);
        // A damper before the bar's next strike leaves that strike alone.
        rings.strike(0, strike(1000, 79), &mut events);
        rings.damp(0, 1000 * 1_000_000, &mut events);
        rings.damp(1, 1000 * 1_000_000, &mut events);
        rings.finish(&mut events);
        assert_eq!(
            events,
            vec![
                strike(0, 79),
                released(300, 79),
                strike(1000, 79),
                released(9000, 79)
            ]
        );
    }

    #[test]
    fn a_strike_rings_until_its_output_strikes_again_or_for_eight_seconds() {
        let mut events = Vec::new();
        let mut rings = Rings::new(2);
        // The hi-hat (output 0) open, then closed: the open one's sound ends there; closed
        // again: the same note ends its own sound (no release of its own).
        rings.strike(0, strike(0, 46), &mut events);
        rings.strike(0, strike(500, 42), &mut events);
        rings.strike(0, strike(600, 42), &mut events);
        // The kick (output 1), then again 9 s later: released 8 s after the first.
        rings.strike(1, strike(100, 36), &mut events);
        rings.strike(1, strike(9100, 36), &mut events);
        rings.finish(&mut events);
        events.sort_by_key(|e| e.at_ns);
        assert_eq!(
            events,
            vec![
                strike(0, 46),
                strike(100, 36),
                released(500, 46),
                strike(500, 42),
                strike(600, 42),
                released(8100, 36),
                released(8600, 42),
                strike(9100, 36),
                released(17_100, 36),
            ]
        );
    }

    #[test]
    fn the_scores_channel_10_plays_the_drum_kit_and_rings_past_its_note_offs() {
        // Channel 10: 42 at 0 (off at 50 ms), 46 at 500 ms; channel 1: 60 at 0, off at 1 s.
        let song = smf(&[
            0x00, 0x99, 42, 100, 0x00, 0x90, 60, 100, 0x30, 0x89, 42, 0, 0x83, 0x30, 0x99, 46, 100,
            0x83, 0x60, 0x80, 60, 0,
        ]);
        let e = from_song(&song);
        let ms = 1_000_000i64;
        let drums: Vec<(i64, u8, bool)> = e
            .iter()
            .filter(|k| k.instrument == Instrument::Drums)
            .map(|k| {
                (
                    k.at_ns / ms,
                    k.note,
                    matches!(k.action, Action::Strike { .. }),
                )
            })
            .collect();
        assert_eq!(
            drums,
            [
                (0, 42, true),
                (500, 46, true),
                (8000, 42, false),
                (8500, 46, false)
            ]
        );
        let piano: Vec<(i64, u8)> = e
            .iter()
            .filter(|k| k.instrument == Instrument::PIANO)
            .map(|k| (k.at_ns / ms, k.note))
            .collect();
        assert_eq!(piano, [(0, 60), (1000, 60)]);
    }

    #[test]
    fn gm_programs_count_from_one_and_the_kit_is_bank_128() {
        assert_eq!(Instrument::gm_program(10), Some(Instrument::Program(9)));
        assert_eq!(Instrument::gm_program(1), Some(Instrument::PIANO));
        assert_eq!(Instrument::gm_program(0), None);
        assert_eq!(Instrument::gm_program(129), None);
        assert_eq!(Instrument::Drums.bank_and_program(), (128, 0));
        assert_eq!(Instrument::Program(9).bank_and_program(), (0, 9));
        assert_eq!(keyboard(126, 5), vec![Output::key(126), Output::key(127)]);
    }
}
