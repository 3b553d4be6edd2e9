//! Solenoids, fingers and keys: from time-stamped pin edges to the sounds a listener hears.
//!
//! [`Mechanics`] is a pure state machine, one per instrument, fed with `(time, key, high/low)`
//! edges in time order ([`Mechanics::edge`]) and closed with [`Mechanics::finish`]. Each key has
//! three figures ([`KeyMechanics`]), with one default for all keys and per-key overrides:
//!
//! - `press_delay`: from the pin going high until the hammer reaches the string (the key sounds);
//! - `release_delay`: from the pin going low until the key is fully up again;
//! - `min_hold`: the shortest pulse that reaches the string.
//!
//! ## Rules, exactly
//!
//! Let the pin go high at `t1` and low at `t2`.
//!
//! 1. If `t2 − t1 ≥ min_hold`, the key sounds: a key-down event at `t1 + press_delay`. This holds
//!    even when `t2 < t1 + press_delay`: once the finger was driven for `min_hold` the strike is
//!    committed and the key sounds at `t1 + press_delay` anyway. (The event is decided at `t2`,
//!    and stamped with its own time, which may lie before or after `t2`.)
//! 2. If `t2 − t1 < min_hold`, the pulse does not reach the string: no event, counted in
//!    [`MechanicsStats::short_pulses`].
//! 3. A key that sounded is fully up again at `t2 + release_delay`, never before its own key-down
//!    time: the key-up event is at `max(t2 + release_delay, key-down time)`.
//! 4. A press that begins (`t3`, pin high) while a sounded key has not yet fully returned
//!    (`t3 <` its key-up time) is a **smear**: the key never came up, so the pending key-up is
//!    cancelled, [`MechanicsStats::smeared_presses`] counts it, and if it is held `min_hold` its
//!    key-down event carries `smeared: true` (counted in [`MechanicsStats::smeared_onsets`]),
//!    not a clean onset. The key-up comes only when the key finally returns.
//! 5. A press at or after the key-up time is a clean re-strike: key-up event, then a clean
//!    key-down ([`MechanicsStats::clean_onsets`]).
//!
//! So for every key the events alternate down, (smeared down…), up; clean onsets are the
//! key-down events with `smeared == false`.
//!
//! A short pulse (rule 2) on a key at rest moves the finger too little to matter: the key counts
//! as up at once. A short pulse during a smear keeps the key from returning, like any press.
//!
//! ## Dynamics: a press at a duty
//!
//! On a PWM board a press has a strength: the duty its solenoid is driven at when the press
//! begins (its strike; [`Mechanics::press_duty`]). An on/off board presses at full power
//! ([`Mechanics::edge`]). Two more figures of each key say what the strength does:
//!
//! - `softest`: the lowest duty that throws the hammer to the string. A press below it makes
//!   no sound at all, however long it is held (rule 2 again, counted in
//!   [`MechanicsStats::too_soft`], and its [`Press::too_soft`] says so).
//! - `soft_press_delay`: the press delay at `softest`. A softer strike travels slower: the delay
//!   grows linearly from `press_delay` at full power to `soft_press_delay` at `softest`.
//!
//! Each sound has a loudness, on the scale of MIDI velocity ([`Press::velocity`]): 1 is the
//! key's softest sound (a strike at `softest`), 127 its loudest (full power), linear in the
//! duty between. A robot whose velocity curve (robot.toml's `[dynamics]`) matches its keys
//! sounds each note at the velocity asked. The duty after the strike (the hold) changes
//! nothing heard; a duty of 0 is the pin going low.
//!
//! ## Beaters: a muted strike
//!
//! A strike output's beater ([`KeyMechanics::mute_after`]) flies for its press delay, strikes,
//! and must come off its drum head or bar: powered against it for longer than `mute_after`
//! after it struck (the pin high past `press_delay + mute_after`), it chokes the sound. The
//! strike still sounds, at its time, but [`Press::muted`] says so and
//! [`MechanicsStats::muted`] counts it.
//!
//! [`Mechanics::finish`] takes every pin still high as going low at the end (counted in
//! [`MechanicsStats::stuck_at_end`]) and emits every pending key-up, even past the end, so every
//! key-down has its key-up.

use std::collections::BTreeMap;

use orch_core::Duration;
use serde::Serialize;

use crate::bus::SimTime;
use crate::wind::{Blown, WindMechanics, WindTrack};

/// The mechanical figures of one key.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KeyMechanics {
    /// From the pin going high until the key sounds.
    pub press_delay: Duration,
    /// From the pin going low until the key is fully up again.
    pub release_delay: Duration,
    /// The shortest time the pin must stay high for the key to sound.
    pub min_hold: Duration,
    /// The lowest strike duty that sounds, in 4095ths of full power (see the
    /// [module notes](self)).
    pub softest: u16,
    /// The press delay of a strike at `softest` (`press_delay` is at full power).
    pub soft_press_delay: Duration,
    /// A beater's (a strike output's): the longest it may stay powered against its drum head
    /// or bar once it has struck before it mutes it; `None` for a key (held down by design).
    pub mute_after: Option<Duration>,
}

impl KeyMechanics {
    /// 15 ms to strike at full power, 30 ms at the softest duty that sounds (45 %), 25 ms to
    /// return, 8 ms shortest pulse that sounds.
    pub const DEFAULT: Self = Self {
        press_delay: Duration::from_millis(15),
        release_delay: Duration::from_millis(25),
        min_hold: Duration::from_millis(8),
        softest: 1843,
        soft_press_delay: Duration::from_millis(30),
        mute_after: None,
    };

    /// Full power, in 4095ths.
    pub const FULL: u16 = 4095;

    /// Whether a strike at `duty` (4095ths) sounds: at or above `softest`.
    pub fn sounds_at(&self, duty: u16) -> bool {
        duty > 0 && duty >= self.softest
    }

    /// The press delay of a strike at `duty` (at least `softest`): `press_delay` at full
    /// power, `soft_press_delay` at `softest`, linear between.
    pub fn press_delay_at(&self, duty: u16) -> Duration {
        let (full, soft) = (
            self.press_delay.as_micros() as i64,
            self.soft_press_delay.as_micros() as i64,
        );
        let span = (Self::FULL as i64 - self.softest as i64).max(0);
        if span == 0 || duty >= Self::FULL {
            return self.press_delay;
        }
        let below = (Self::FULL as i64 - duty.max(self.softest) as i64).min(span);
        let us = full + ((soft - full) * below + span / 2).div_euclid(span);
        Duration::from_micros(us.max(0) as u32)
    }

    /// The loudness of a strike at `duty` on the MIDI velocity scale (1..=127), if it sounds:
    /// [`loudness_at`](Self::loudness_at) to the nearest whole step.
    pub fn velocity_at(&self, duty: u16) -> Option<u8> {
        self.loudness_at(duty).map(Loudness::velocity)
    }

    /// The exact loudness of a strike at `duty`, if it sounds.
    pub fn loudness_at(&self, duty: u16) -> Option<Loudness> {
        if !self.sounds_at(duty) {
            return None;
        }
        let span = Self::FULL.saturating_sub(self.softest);
        Some(Loudness {
            above: duty.min(Self::FULL) - self.softest,
            span,
        })
    }
}

/// How loud a strike sounds, exactly, on the MIDI velocity scale: 1 at the key's softest
/// duty, 127 at full power, linear in the duty between. A solenoid's strike is not made in
/// whole steps: [`Press::velocity`] is this to the nearest step (what reports show), and
/// `orch render` plays this (so a strike's sound follows its duty to the 4095th).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Loudness {
    /// The strike's duty above the key's softest, 4095ths.
    above: u16,
    /// Full power above the key's softest, 4095ths (0: a key that sounds only at full power).
    span: u16,
}

impl Loudness {
    /// Exactly a MIDI velocity, 1..=127 (0 is taken as 1): a score's note as written.
    pub fn of_velocity(velocity: u8) -> Self {
        Self {
            above: u16::from(velocity.clamp(1, 127)) - 1,
            span: 126,
        }
    }

    /// On the velocity scale, 1.0..=127.0.
    pub fn get(self) -> f64 {
        if self.span == 0 {
            return 127.0;
        }
        1.0 + 126.0 * f64::from(self.above) / f64::from(self.span)
    }

    /// To the nearest whole step, 1..=127 (a half step rounds up).
    pub fn velocity(self) -> u8 {
        if self.span == 0 {
            return 127;
        }
        let (above, span) = (u32::from(self.above), u32::from(self.span));
        (1 + (126 * above + span / 2) / span) as u8
    }
}

impl Serialize for Loudness {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(self.get())
    }
}

impl Default for KeyMechanics {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The figures of every key: a default and per-key overrides.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct MechanicsConfig {
    /// Figures of every key without an override.
    pub default: KeyMechanics,
    /// Per-key figures, by key index (0 = lowest key).
    pub overrides: BTreeMap<u8, KeyMechanics>,
    /// A fingered group among the keys (a wind robot's valve and fingers), if any: its
    /// cracks and its loudness by breath ([`wind`](crate::wind)).
    pub wind: Option<WindMechanics>,
}

impl MechanicsConfig {
    /// Every key with the same figures.
    pub fn uniform(default: KeyMechanics) -> Self {
        Self {
            default,
            overrides: BTreeMap::new(),
            wind: None,
        }
    }

    /// The same, with `key` given its own figures.
    pub fn with_key(mut self, key: u8, figures: KeyMechanics) -> Self {
        self.overrides.insert(key, figures);
        self
    }

    /// The figures of `key`.
    pub fn for_key(&self, key: u8) -> KeyMechanics {
        self.overrides.get(&key).copied().unwrap_or(self.default)
    }
}

/// Key-down (the key sounds) or key-up (the key is fully up again).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SoundKind {
    /// The hammer reaches the string.
    Down,
    /// The key is fully up again.
    Up,
}

/// One thing a listener hears (or the key's return).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct SoundEvent {
    /// When.
    pub time: SimTime,
    /// Key index, 0 = lowest key.
    pub key: u8,
    /// Down or up.
    pub kind: SoundKind,
    /// A key-down from a press that began before the key had fully returned: not a clean
    /// onset. Always `false` for key-up events.
    pub smeared: bool,
}

/// One press of a key (the pin high, then low), and what it gave: decided when the pin goes
/// low (or at [`Mechanics::finish`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Press {
    /// Key index, 0 = lowest key.
    pub key: u8,
    /// When the pin went high.
    pub pin_high: SimTime,
    /// When the pin went low.
    pub pin_low: SimTime,
    /// When it sounded, if it did (held at least `min_hold`).
    pub sounded: Option<SimTime>,
    /// It began before the key had fully returned (rule 4).
    pub smeared: bool,
    /// The strike's duty, in 4095ths ([`KeyMechanics::FULL`] on an on/off board).
    pub duty: u16,
    /// How loud it sounded, exactly; `None` if it made no sound. [`Press::velocity`] is it to
    /// the nearest step.
    pub loudness: Option<Loudness>,
    /// It made no sound because its duty was below the key's softest.
    pub too_soft: bool,
    /// A beater that sounded but stayed powered against its head or bar past its
    /// `mute_after`: when that choked the sound (its strike plus `mute_after`); `None` when it
    /// was not choked.
    pub muted: Option<SimTime>,
    /// A wind robot's valve that opened before its fingers had settled, or stayed open while
    /// a finger moved: the note cracked, no note was heard ([`wind`](crate::wind)).
    pub cracked: bool,
}

impl Press {
    /// How loud it sounded, on the MIDI velocity scale (1..=127, to the nearest step); `None`
    /// if it made no sound.
    pub fn velocity(&self) -> Option<u8> {
        self.loudness.map(Loudness::velocity)
    }
}

/// What the mechanics counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct MechanicsStats {
    /// Key-down events from a key that was fully up.
    pub clean_onsets: u64,
    /// Presses that began before the key had fully returned (rule 4), sounding or not.
    pub smeared_presses: u64,
    /// Key-down events from smeared presses.
    pub smeared_onsets: u64,
    /// Pulses shorter than `min_hold`.
    pub short_pulses: u64,
    /// Presses whose strike duty was below the key's softest: no sound.
    pub too_soft: u64,
    /// Strikes that sounded but whose beater stayed on its head or bar past `mute_after`.
    pub muted: u64,
    /// Openings of a wind robot's valve that cracked: no note heard.
    pub cracked: u64,
    /// Key-up events.
    pub key_ups: u64,
    /// Pins still high when [`Mechanics::finish`] was called.
    pub stuck_at_end: u64,
    /// Edges for keys past the last key, ignored.
    pub ignored_edges: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum KeyState {
    /// Fully up.
    Up,
    /// Pin high since `since`.
    Pressing {
        since: SimTime,
        smeared: bool,
        was_sounding: bool,
        /// The strike's duty.
        duty: u16,
    },
    /// Pin low; the sounded key is fully up at `returns_at`.
    Returning { returns_at: SimTime },
}

/// The solenoid and key state machine. See the [module notes](self) for the rules.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Mechanics {
    figures: Vec<KeyMechanics>,
    state: Vec<KeyState>,
    last_down: Vec<SimTime>,
    events: Vec<SoundEvent>,
    presses: Vec<Press>,
    keep_sounds: bool,
    stats: MechanicsStats,
    wind: Option<WindTrack>,
    /// Per key: its key-down events, clean and smeared.
    onsets: Vec<u64>,
}

impl Mechanics {
    /// `keys` keys at rest, with their figures from `config`.
    pub fn new(keys: usize, config: &MechanicsConfig) -> Self {
        Self {
            figures: (0..keys).map(|k| config.for_key(k as u8)).collect(),
            state: vec![KeyState::Up; keys],
            last_down: vec![SimTime::ZERO; keys],
            events: Vec::new(),
            presses: Vec::new(),
            keep_sounds: true,
            stats: MechanicsStats::default(),
            wind: config.wind.clone().map(WindTrack::new),
            onsets: vec![0; keys],
        }
    }

    /// How many keys.
    pub fn keys(&self) -> usize {
        self.state.len()
    }

    /// The figures of `key`.
    pub fn figures(&self, key: u8) -> Option<KeyMechanics> {
        self.figures.get(key as usize).copied()
    }

    /// The counters so far.
    pub fn stats(&self) -> MechanicsStats {
        self.stats
    }

    /// Per key: its key-down events so far, clean and smeared (kept whether or not the
    /// events are).
    pub fn onsets(&self) -> &[u64] {
        &self.onsets
    }

    /// The events decided so far, in the order they were decided (not always time order;
    /// [`finish`](Self::finish) sorts them).
    pub fn events(&self) -> &[SoundEvent] {
        &self.events
    }

    /// Every press decided so far, in the order the pins went low (per key: in press order).
    pub fn presses(&self) -> &[Press] {
        &self.presses
    }

    /// Hands the presses decided so far to `f`, oldest first, and forgets them.
    pub fn drain_presses(&mut self, f: impl FnMut(&Press)) {
        self.presses.iter().for_each(f);
        self.presses.clear();
    }

    /// Takes the presses decided so far out of the mechanics.
    pub fn take_presses(&mut self) -> Vec<Press> {
        core::mem::take(&mut self.presses)
    }

    /// Whether `key`'s pin is high.
    pub fn pin_high(&self, key: u8) -> bool {
        matches!(
            self.state.get(key as usize),
            Some(KeyState::Pressing { .. })
        )
    }

    /// Whether to keep the sound events ([`events`](Self::events), [`finish`](Self::finish)):
    /// off, only the presses and the counters are kept.
    pub fn keep_sounds(&mut self, keep: bool) {
        self.keep_sounds = keep;
    }

    fn emit(&mut self, time: SimTime, key: u8, kind: SoundKind, smeared: bool) {
        if !self.keep_sounds {
            return;
        }
        self.events.push(SoundEvent {
            time,
            key,
            kind,
            smeared,
        });
    }

    /// `key`'s pin went high (`true`, at full power) or low at `time`. Edges must come in time
    /// order; an edge to the level the pin already has is ignored.
    pub fn edge(&mut self, time: SimTime, key: u8, high: bool) {
        self.press_duty(time, key, if high { KeyMechanics::FULL } else { 0 });
    }

    /// `key`'s solenoid is driven at `duty` (4095ths; 0 is the pin low) from `time`. A press
    /// begins when the duty leaves 0 and takes that duty as its strike; a change of duty while
    /// pressing (the hold) changes nothing heard; 0 ends the press. Times must not go back.
    pub fn press_duty(&mut self, time: SimTime, key: u8, duty: u16) {
        let k = key as usize;
        let high = duty > 0;
        if k >= self.state.len() {
            self.stats.ignored_edges += 1;
            return;
        }
        let figures = self.figures[k];
        let state = self.state[k];
        if let Some(w) = &mut self.wind {
            let moves = match state {
                KeyState::Pressing { .. } => !high,
                _ => high,
            };
            if moves {
                let travel = if high {
                    figures.press_delay
                } else {
                    figures.release_delay
                };
                w.moved(time, key, high, travel);
            }
        }
        match (state, high) {
            (KeyState::Up, true) => {
                self.state[k] = KeyState::Pressing {
                    since: time,
                    smeared: false,
                    was_sounding: false,
                    duty,
                };
            }
            (KeyState::Returning { returns_at }, true) => {
                if time >= returns_at {
                    self.emit(returns_at, key, SoundKind::Up, false);
                    self.stats.key_ups += 1;
                    self.state[k] = KeyState::Pressing {
                        since: time,
                        smeared: false,
                        was_sounding: false,
                        duty,
                    };
                } else {
                    self.stats.smeared_presses += 1;
                    self.state[k] = KeyState::Pressing {
                        since: time,
                        smeared: true,
                        was_sounding: true,
                        duty,
                    };
                }
            }
            (
                KeyState::Pressing {
                    since,
                    smeared,
                    was_sounding,
                    duty: strike,
                },
                false,
            ) => self.release(time, key, since, smeared, was_sounding, strike),
            // Same level again: nothing moves.
            (KeyState::Pressing { .. }, true)
            | (KeyState::Up, false)
            | (KeyState::Returning { .. }, false) => {}
        }
    }

    /// `key`'s pin went low at `time`, ending its press from `since` at `strike`: the press
    /// is decided (rules 1 to 3; a wind valve's crack and breath).
    fn release(
        &mut self,
        time: SimTime,
        key: u8,
        since: SimTime,
        smeared: bool,
        was_sounding: bool,
        strike: u16,
    ) {
        let k = key as usize;
        let figures = self.figures[k];
        let blown = match &mut self.wind {
            Some(w) if w.is_valve(key) => w.closed(strike),
            _ => Blown {
                cracked: false,
                heard_duty: strike,
            },
        };
        let heard = blown.heard_duty;
        let long = time.nanos_since(since) >= figures.min_hold.as_micros() as u64 * 1_000;
        let cracked = long && blown.cracked;
        let too_soft = long && !cracked && !figures.sounds_at(heard);
        let sounds = long && !too_soft && !cracked;
        let delay = figures.press_delay_at(heard);
        // Powered on past its contact by more than it may be: the bar is choked.
        let muted = figures
            .mute_after
            .map(|m| since + delay + m)
            .filter(|&choked| sounds && time > choked);
        self.stats.muted += u64::from(muted.is_some());
        self.stats.cracked += u64::from(cracked);
        self.presses.push(Press {
            key,
            pin_high: since,
            pin_low: time,
            sounded: sounds.then(|| since + delay),
            smeared,
            duty: strike,
            loudness: if sounds {
                figures.loudness_at(heard)
            } else {
                None
            },
            too_soft,
            muted,
            cracked,
        });
        if too_soft {
            self.stats.too_soft += 1;
        }
        let sounding = if sounds {
            let down = since + delay;
            self.emit(down, key, SoundKind::Down, smeared);
            if smeared {
                self.stats.smeared_onsets += 1;
            } else {
                self.stats.clean_onsets += 1;
            }
            self.last_down[k] = down;
            self.onsets[k] += 1;
            true
        } else {
            if !too_soft && !cracked {
                self.stats.short_pulses += 1;
            }
            was_sounding
        };
        self.state[k] = if sounding {
            KeyState::Returning {
                returns_at: (time + figures.release_delay).max(self.last_down[k]),
            }
        } else {
            KeyState::Up
        };
    }

    /// Closes the performance at `end`: every pin still high goes low at `end` (or at its
    /// press, if later), every pending key-up is emitted. Returns every event so far, sorted by
    /// time (events at the same time keep the order they were decided in), and leaves every key
    /// at rest with no events.
    pub fn finish(&mut self, end: SimTime) -> Vec<SoundEvent> {
        for k in 0..self.state.len() {
            if let KeyState::Pressing { since, .. } = self.state[k] {
                self.stats.stuck_at_end += 1;
                self.edge(end.max(since), k as u8, false);
            }
            if let KeyState::Returning { returns_at } = self.state[k] {
                self.emit(returns_at, k as u8, SoundKind::Up, false);
                self.stats.key_ups += 1;
            }
            self.state[k] = KeyState::Up;
        }
        let mut events = core::mem::take(&mut self.events);
        events.sort_by_key(|e| e.time);
        events
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t: u64) -> SimTime {
        SimTime::from_millis(t)
    }

    #[test]
    fn committed_strike_sounds_after_an_early_release() {
        // Held 10 ms ≥ min_hold 8 ms, released before the 15 ms press delay: still sounds at 15.
        let mut m = Mechanics::new(1, &MechanicsConfig::default());
        m.edge(ms(0), 0, true);
        m.edge(ms(10), 0, false);
        let ev = m.finish(ms(100));
        assert_eq!(ev[0].time, ms(15));
        assert_eq!(ev[0].kind, SoundKind::Down);
        assert_eq!(ev[1].time, ms(35));
    }

    #[test]
    fn a_beater_left_on_its_bar_past_mute_after_is_muted_but_still_sounds() {
        let beater = KeyMechanics {
            press_delay: Duration::from_millis(6),
            release_delay: Duration::from_millis(10),
            min_hold: Duration::from_millis(3),
            mute_after: Some(Duration::from_millis(10)),
            ..KeyMechanics::DEFAULT
        };
        let mut m = Mechanics::new(1, &MechanicsConfig::uniform(beater));
        // 12 ms: on the bar 6 ms. 16 ms: 10 ms, the most it may. 17 ms: muted.
        for (at, len) in [(0, 12), (100, 16), (200, 17)] {
            m.edge(ms(at), 0, true);
            m.edge(ms(at + len), 0, false);
        }
        let muted: Vec<_> = m.presses().iter().map(|p| p.muted).collect();
        // Choked when it had rested on the bar 10 ms: 6 ms flight, then 10 ms.
        assert_eq!(muted, [None, None, Some(ms(216))]);
        assert!(m.presses().iter().all(|p| p.sounded.is_some()));
        assert_eq!(m.stats().muted, 1);
        // A key (no mute_after) is never muted however long it is held.
        let mut k = Mechanics::new(1, &MechanicsConfig::default());
        k.edge(ms(0), 0, true);
        k.edge(ms(5_000), 0, false);
        assert_eq!(k.presses()[0].muted, None);
    }

    #[test]
    fn key_up_never_precedes_key_down() {
        let fig = KeyMechanics {
            press_delay: Duration::from_millis(30),
            release_delay: Duration::from_millis(5),
            min_hold: Duration::from_millis(8),
            ..KeyMechanics::DEFAULT
        };
        let mut m = Mechanics::new(1, &MechanicsConfig::uniform(fig));
        m.edge(ms(0), 0, true);
        m.edge(ms(10), 0, false);
        let ev = m.finish(ms(100));
        assert_eq!((ev[0].time, ev[1].time), (ms(30), ms(30)));
    }

    #[test]
    fn finish_releases_a_stuck_pin_and_counts_it() {
        let mut m = Mechanics::new(2, &MechanicsConfig::default());
        m.edge(ms(0), 1, true);
        let ev = m.finish(ms(50));
        assert_eq!(m.stats().stuck_at_end, 1);
        assert_eq!(ev.len(), 2);
        assert_eq!(ev[1].time, ms(75));
        assert!(m.events().is_empty());
    }

    #[test]
    fn edges_past_the_last_key_are_ignored() {
        let mut m = Mechanics::new(2, &MechanicsConfig::default());
        m.edge(ms(0), 5, true);
        assert_eq!(m.stats().ignored_edges, 1);
    }

    #[test]
    fn a_softer_strike_sounds_later_and_softer_and_below_the_softest_not_at_all() {
        let k = KeyMechanics::DEFAULT;
        assert_eq!(k.press_delay_at(4095), Duration::from_millis(15));
        assert_eq!(k.press_delay_at(1843), Duration::from_millis(30));
        assert_eq!(k.velocity_at(4095), Some(127));
        assert_eq!(k.velocity_at(1843), Some(1));
        assert_eq!(k.velocity_at(1842), None);
        // Exact between the steps; the velocity is it to the nearest step.
        assert_eq!(k.loudness_at(1843).unwrap().get(), 1.0);
        assert_eq!(k.loudness_at(4095).unwrap().get(), 127.0);
        assert!(
            (k.loudness_at(2000).unwrap().get() - (1.0 + 126.0 * 157.0 / 2252.0)).abs() < 1e-12
        );
        for duty in 1843..=4095 {
            let exact = k.loudness_at(duty).unwrap();
            assert_eq!(exact.velocity(), k.velocity_at(duty).unwrap());
            assert!(
                (f64::from(exact.velocity()) - exact.get()).abs() <= 0.5,
                "duty {duty}"
            );
        }
        assert_eq!(Loudness::of_velocity(64).get(), 64.0);
        assert_eq!(Loudness::of_velocity(64).velocity(), 64);
        assert_eq!(Loudness::of_velocity(0).get(), 1.0);
        let mut last = (Duration::from_millis(31), 0);
        for duty in 1843..=4095 {
            let (d, v) = (k.press_delay_at(duty), k.velocity_at(duty).unwrap());
            assert!(d <= last.0 && v >= last.1, "duty {duty}");
            last = (d, v);
        }
        let mut m = Mechanics::new(1, &MechanicsConfig::default());
        m.press_duty(ms(0), 0, 1000);
        m.press_duty(ms(100), 0, 0);
        m.press_duty(ms(200), 0, 2969); // 1843 + half the span: velocity 64, 22.5 ms
        m.press_duty(ms(240), 0, 1433); // the hold changes nothing heard
        m.press_duty(ms(400), 0, 0);
        let p = m.presses().to_vec();
        assert!(p[0].too_soft && p[0].sounded.is_none() && p[0].velocity().is_none());
        assert_eq!(p[1].velocity(), Some(64));
        assert_eq!(p[1].sounded, Some(SimTime::from_micros(222_500)));
        assert_eq!(p[1].duty, 2969);
        assert_eq!(m.stats().too_soft, 1);
        assert_eq!(m.stats().short_pulses, 0);
        assert_eq!(m.stats().clean_onsets, 1);
    }
}
