//! Strike groups: percussion and mallets, played by pulses.
//!
//! A keyboard key is held down while its note sounds. A drum's or a bar's beater is not: a
//! Note-On fires its solenoid for a short **pulse**, whatever the note's length, and the
//! Note-Off does nothing. A robot may have, beside its keyboard, up to
//! [`MAX_STRIKE_GROUPS`] strike groups ([`Strikes`]), each with its own channels and its own
//! outputs: keys numbered after the keyboard's (or from 0 with no keyboard), on the boards
//! of the layout in order.
//!
//! - An **unpitched** group (a drum kit) maps notes sparsely to its outputs: several notes
//!   may share one (GM 35 and 36 both the kick); a note with no output is dropped as
//!   [`DropReason::Unmapped`](crate::DropReason::Unmapped).
//! - A **pitched** group (a glockenspiel, a xylophone) has a range of notes, one output a
//!   note, and folds notes out of range by octaves as the keyboard does.
//!
//! Each output has its [`Pulse`]: the pulse's length by velocity, and its **rebound**, the
//! shortest time from one strike of its beater to the next. The guard keeps them:
//!
//! - a pulse ends by itself, whatever the Note-Off does and whenever it comes, and never
//!   lasts longer than the guard's [`max_pulse`](crate::GuardConfig::max_pulse) (a beater
//!   left on its bar mutes it; a stuck output burns its coil);
//! - a strike that arrives while its beater's pulse is on joins that strike (the same hit);
//! - a strike within the rebound waits for it, as a keyboard's re-strike waits for its rest,
//!   and is dropped as too fast past the guard's `late_limit`;
//! - strikes count against the power budget while their pulse is on (by their duty with
//!   [`Dynamics`](crate::Dynamics)), and the watchdog and `all_off` end every pulse.
//!
//! On a PWM board a strike's duty is its velocity's on the output's [`Touch`](crate::Touch)
//! curve, for the whole pulse (no hold): its energy, duty × length, never falls as velocity
//! rises.
//!
//! A note goes to the first strike group that listens to its channel and has an output for
//! it, else to the keyboard if it listens to the channel.
//!
//! Needs the `strike` feature (on by default, off on the ATmega16).

use crate::keymap::{KeyOf, KeyRange, OutOfRange};
use crate::time::Duration;
use crate::values::{Channel, ChannelMask, Note, Velocity};

/// The most strike groups a robot may have.
pub const MAX_STRIKE_GROUPS: usize = 4;

/// The longest a strike's pulse may be made, whatever the guard says: 250 ms.
pub const MAX_PULSE: Duration = Duration::from_millis(250);

/// How one output strikes: its pulse's length by velocity and its beater's rebound.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Pulse {
    /// The pulse of velocity 1.
    pub soft: Duration,
    /// The pulse of velocity 127 (at least `soft`).
    pub loud: Duration,
    /// The shortest time from one strike's start to the next's.
    pub rebound: Duration,
}

impl Pulse {
    /// The default for a drum's beater: 8 ms soft (Adafruit's solenoid drummer, jzkmath's
    /// and NeilFraser's builds all fire 8 ms) to 20 ms loud (glloq's xylophone fires 20 ms),
    /// and a 40 ms rebound (25 strikes a second: faster than a drummer's single-stroke roll).
    pub const DRUM: Self = Self {
        soft: Duration::from_millis(8),
        loud: Duration::from_millis(20),
        rebound: Duration::from_millis(40),
    };

    /// Not a strike output (a keyboard key): no pulse.
    pub const NONE: Self = Self {
        soft: Duration::ZERO,
        loud: Duration::ZERO,
        rebound: Duration::ZERO,
    };

    /// The pulse's length at `velocity`: `soft` at 1, `loud` at 127, linear in between
    /// (rounded to the nearest µs), never falling.
    pub const fn length(&self, velocity: Velocity) -> Duration {
        let v = if velocity.get() == 0 {
            1
        } else {
            velocity.get() as u64
        };
        let (lo, hi) = (self.soft.as_micros() as u64, self.loud.as_micros() as u64);
        if hi <= lo {
            return self.soft;
        }
        Duration::from_micros((lo + ((hi - lo) * (v - 1) + 63) / 126) as u32)
    }

    /// Whether this is a strike output.
    pub const fn is_strike(&self) -> bool {
        self.loud.as_micros() > 0
    }
}

/// How a strike group finds a note's output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StrikeNotes {
    /// A sparse map, note by note ([`Strikes::map`]): a drum kit.
    Sparse,
    /// A range of notes, one output each, in order from the group's first output; notes
    /// outside it fold by octaves or are dropped: a glockenspiel.
    Range(KeyRange, OutOfRange),
}

/// One strike group: its channels, its outputs and how notes find them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StrikeGroup {
    /// Channels listened to.
    pub channels: ChannelMask,
    /// Its first output: a key of the robot.
    pub first: u8,
    /// How many outputs it has.
    pub outputs: u8,
    /// How notes find its outputs.
    pub notes: StrikeNotes,
}

impl StrikeGroup {
    /// No group.
    pub const EMPTY: Self = Self {
        channels: ChannelMask(0),
        first: 0,
        outputs: 0,
        notes: StrikeNotes::Sparse,
    };
}

/// A robot's strike groups and the pulse of each of their outputs.
///
/// Beside the outputs notes strike, a group may have:
///
/// - **lead** outputs ([`set_lead`](Self::set_lead)): a note with a lead fires it first and
///   strikes its own output the lead output's [`lead time`](Self::lead_times) later (an
///   open hi-hat: the lift opens the cymbals, then the stick strikes them);
/// - **dampers** ([`set_damper`](Self::set_damper)): an output fired at the Note-Off of a
///   note that struck its bar, once the beater's pulse is over and not while the channel's
///   sustain pedal holds (then when it goes up). A bar's damper is never on while its beater
///   strikes: a strike cuts its damper's pulse.
///
/// Lead and damper outputs are outputs of their group like any other (a pitched group's
/// come after its range: [`add_outputs`](Self::add_outputs)), with their own pulse.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Strikes {
    /// Whether the robot has a keyboard (`Config::range`'s keys, first in the layout). Without
    /// one the strike groups' outputs start at key 0 and the keyboard plays nothing.
    pub keyboard: bool,
    /// The groups, `count` of them used.
    pub groups: [StrikeGroup; MAX_STRIKE_GROUPS],
    /// How many groups are used.
    pub count: u8,
    /// The sparse groups' note maps: `map[g][note]` is the output (a key) plus one, 0 for
    /// none.
    pub map: [[u8; 128]; MAX_STRIKE_GROUPS],
    /// The sparse groups' leads: `leads[g][note]` is the output (a key) plus one that fires
    /// before the note's own, 0 for none.
    pub leads: [[u8; 128]; MAX_STRIKE_GROUPS],
    /// Every lead output's lead time: how long before the note's own output it fires (the
    /// lift's travel). Below the rebound of every output it leads.
    pub lead_times: [Duration; 128],
    /// Every output's damper: `dampers[key]` is the damper output (a key) plus one, 0 for
    /// none.
    pub dampers: [u8; 128],
    /// Every key's pulse; [`Pulse::NONE`] for a keyboard key.
    pub pulses: [Pulse; 128],
}

impl Strikes {
    /// A keyboard alone.
    pub const NONE: Self = Self {
        keyboard: true,
        groups: [StrikeGroup::EMPTY; MAX_STRIKE_GROUPS],
        count: 0,
        map: [[0; 128]; MAX_STRIKE_GROUPS],
        leads: [[0; 128]; MAX_STRIKE_GROUPS],
        lead_times: [Duration::ZERO; 128],
        dampers: [0; 128],
        pulses: [Pulse::NONE; 128],
    };

    /// The groups in use.
    pub fn groups(&self) -> &[StrikeGroup] {
        &self.groups[..self.count as usize]
    }

    /// How many outputs the strike groups have.
    pub fn outputs(&self) -> usize {
        self.groups().iter().map(|g| g.outputs as usize).sum()
    }

    /// The pulse of `key`; [`Pulse::NONE`] for a keyboard key.
    #[inline]
    pub fn pulse(&self, key: u8) -> Pulse {
        self.pulses
            .get(key as usize)
            .copied()
            .unwrap_or(Pulse::NONE)
    }

    /// The first key after the keyboard's `keyboard_keys` keys and the groups so far.
    const fn next_key(&self, keyboard_keys: usize) -> usize {
        let mut next = if self.keyboard { keyboard_keys } else { 0 };
        let mut g = 0;
        while g < self.count as usize && g < MAX_STRIKE_GROUPS {
            next += self.groups[g].outputs as usize;
            g += 1;
        }
        next
    }

    /// Adds an unpitched group (a drum kit) after the last one, on `channels`: output `i`
    /// plays the notes `outputs[i].0` with the pulse `outputs[i].1`. A note named twice plays
    /// its first output. `keyboard_keys` is the keyboard's range's keys (ignored without a
    /// keyboard).
    ///
    /// A `const fn`: a fixed robot's kit (an MCU's) can be built in a `const` item, checked
    /// when it is compiled (see [`Strikes::with_kit`]).
    pub const fn push_kit(
        &mut self,
        channels: ChannelMask,
        keyboard_keys: usize,
        outputs: &[(&[u8], Pulse)],
    ) -> Result<(), StrikeError> {
        let g = self.count as usize;
        let first = self.next_key(keyboard_keys);
        if g >= MAX_STRIKE_GROUPS {
            return Err(StrikeError::TooManyGroups);
        }
        if outputs.is_empty() || first + outputs.len() > self.pulses.len() {
            return Err(StrikeError::Span { group: g as u8 });
        }
        self.map[g] = [0; 128];
        // `while` loops: a `const fn` has no iterators.
        let mut i = 0;
        while i < outputs.len() {
            let (notes, pulse) = outputs[i];
            let key = first + i;
            self.pulses[key] = pulse;
            let mut j = 0;
            while j < notes.len() {
                let n = notes[j] as usize;
                if n >= self.map[g].len() {
                    return Err(StrikeError::Map { group: g as u8 });
                }
                if self.map[g][n] == 0 {
                    self.map[g][n] = key as u8 + 1;
                }
                j += 1;
            }
            i += 1;
        }
        self.groups[g] = StrikeGroup {
            channels,
            first: first as u8,
            outputs: outputs.len() as u8,
            notes: StrikeNotes::Sparse,
        };
        self.count += 1;
        Ok(())
    }

    /// [`push_kit`](Self::push_kit) on a copy, for a `const` item: the strikes with the kit
    /// added. Panics if `push_kit` would refuse it (in a `const` item: the build fails).
    pub const fn with_kit(
        mut self,
        channels: ChannelMask,
        keyboard_keys: usize,
        outputs: &[(&[u8], Pulse)],
    ) -> Self {
        match self.push_kit(channels, keyboard_keys, outputs) {
            Ok(()) => self,
            Err(_) => panic!("Strikes::with_kit: push_kit refused the kit"),
        }
    }

    /// Adds a pitched group (a glockenspiel) after the last one, on `channels`: one output a
    /// note of `range`, each with `pulse`, notes outside it folded or dropped by `policy`.
    pub fn push_pitched(
        &mut self,
        channels: ChannelMask,
        keyboard_keys: usize,
        range: KeyRange,
        policy: OutOfRange,
        pulse: Pulse,
    ) -> Result<(), StrikeError> {
        let g = self.count as usize;
        let first = self.next_key(keyboard_keys);
        if g >= MAX_STRIKE_GROUPS {
            return Err(StrikeError::TooManyGroups);
        }
        if first + range.keys() > self.pulses.len() {
            return Err(StrikeError::Span { group: g as u8 });
        }
        for p in &mut self.pulses[first..first + range.keys()] {
            *p = pulse;
        }
        self.groups[g] = StrikeGroup {
            channels,
            first: first as u8,
            outputs: range.keys() as u8,
            notes: StrikeNotes::Range(range, policy),
        };
        self.count += 1;
        Ok(())
    }

    /// Adds `count` outputs with `pulse` after the last group's (it must have one): a
    /// pitched group's dampers, say. Returns the first new output's key.
    pub fn add_outputs(&mut self, count: usize, pulse: Pulse) -> Result<u8, StrikeError> {
        let Some(g) = (self.count as usize).checked_sub(1) else {
            return Err(StrikeError::Span { group: 0 });
        };
        let group = &mut self.groups[g];
        let first = group.first as usize + group.outputs as usize;
        if count == 0 || first + count > self.pulses.len() {
            return Err(StrikeError::Span { group: g as u8 });
        }
        group.outputs += count as u8;
        for p in &mut self.pulses[first..first + count] {
            *p = pulse;
        }
        Ok(first as u8)
    }

    /// Makes `note` of sparse group `group` fire `lead` (an output) `time` before its own
    /// output: an open hi-hat's lift. Checked by [`validate`](Self::validate).
    pub fn set_lead(&mut self, group: usize, note: Note, lead: u8, time: Duration) {
        if let (Some(leads), Some(t)) = (
            self.leads.get_mut(group),
            self.lead_times.get_mut(lead as usize),
        ) {
            leads[note.get() as usize] = lead.wrapping_add(1);
            *t = time;
        }
    }

    /// Gives `output` the damper `damper` (another output), fired at its notes' Note-Offs.
    /// Checked by [`validate`](Self::validate).
    pub fn set_damper(&mut self, output: u8, damper: u8) {
        if let Some(d) = self.dampers.get_mut(output as usize) {
            *d = damper.wrapping_add(1);
        }
    }

    /// The lead of a note on `channel`: the output that fires first and how long before
    /// the note's own, if the note's group gives it one.
    pub fn lead(&self, channel: Channel, note: Note) -> Option<(u8, Duration)> {
        let (g, _) = self.find_in(channel, note)?.ok()?;
        let lead = self.leads[g][note.get() as usize].checked_sub(1)?;
        Some((lead, self.lead_times[lead as usize]))
    }

    /// Whether `key` is a lead or a damper: an output no note strikes itself.
    pub fn is_extra(&self, key: u8) -> bool {
        let k = key.wrapping_add(1);
        self.dampers.contains(&k)
            || self
                .groups()
                .iter()
                .enumerate()
                .any(|(g, _)| self.leads[g].contains(&k))
    }

    /// The damper of `output`, if it has one.
    #[inline]
    pub fn damper(&self, output: u8) -> Option<u8> {
        self.dampers.get(output as usize)?.checked_sub(1)
    }

    /// Where a note on `channel` goes: `Some(Ok(key))` to a strike group's output, `Some(Err(reason))`
    /// if some strike group listens to the channel but none has an output for it (and the
    /// keyboard does not take it: see [`Config::land`](crate::Config::land)), `None` if no
    /// strike group listens.
    pub fn find(&self, channel: Channel, note: Note) -> Option<Result<KeyOf, StrikeMiss>> {
        self.find_in(channel, note).map(|r| r.map(|(_, of)| of))
    }

    /// [`find`](Self::find), with the group found.
    fn find_in(&self, channel: Channel, note: Note) -> Option<Result<(usize, KeyOf), StrikeMiss>> {
        let mut miss = None;
        for (g, group) in self.groups().iter().enumerate() {
            if !group.channels.contains(channel) {
                continue;
            }
            match group.notes {
                StrikeNotes::Sparse => match self.map[g][note.get() as usize] {
                    0 => miss = Some(StrikeMiss::Unmapped),
                    k => {
                        return Some(Ok((
                            g,
                            KeyOf {
                                key: k - 1,
                                octaves: 0,
                            },
                        )))
                    }
                },
                StrikeNotes::Range(range, policy) => match range.key_for(note, policy) {
                    Some(of) => {
                        return Some(Ok((
                            g,
                            KeyOf {
                                key: group.first + of.key,
                                octaves: of.octaves,
                            },
                        )))
                    }
                    None => miss = miss.or(Some(StrikeMiss::Range)),
                },
            }
        }
        miss.map(Err)
    }

    /// Checks the groups against a layout of `keys` keys and a keyboard of `keyboard_keys`.
    pub fn validate(
        &self,
        keyboard_keys: usize,
        keys: usize,
        max_pulse: Duration,
    ) -> Result<(), StrikeError> {
        let first = if self.keyboard { keyboard_keys } else { 0 };
        if self.count as usize > MAX_STRIKE_GROUPS {
            return Err(StrikeError::TooManyGroups);
        }
        if first + self.outputs() != keys {
            return Err(StrikeError::Outputs {
                outputs: first + self.outputs(),
                layout: keys,
            });
        }
        let mut next = first;
        for (g, group) in self.groups().iter().enumerate() {
            let group_no = g as u8;
            if group.first as usize != next || group.outputs == 0 {
                return Err(StrikeError::Span { group: group_no });
            }
            next += group.outputs as usize;
            let span = group.first..group.first + group.outputs;
            match group.notes {
                StrikeNotes::Sparse => {
                    if self.map[g]
                        .iter()
                        .any(|&k| k != 0 && !span.contains(&(k - 1)))
                    {
                        return Err(StrikeError::Map { group: group_no });
                    }
                }
                StrikeNotes::Range(range, _) => {
                    if range.keys() > group.outputs as usize
                        || self.leads[g].iter().any(|&k| k != 0)
                    {
                        return Err(StrikeError::Span { group: group_no });
                    }
                }
            }
            self.validate_leads(g, span.clone())?;
            for key in span.clone() {
                if let Some(d) = self.damper(key) {
                    let shared = span.clone().any(|k| k != key && self.damper(k) == Some(d));
                    if !span.contains(&d)
                        || self.plays_notes(g, d)
                        || self.damper(d).is_some()
                        || shared
                    {
                        return Err(StrikeError::Damper { key });
                    }
                }
            }
            for key in span {
                let p = self.pulse(key);
                if !p.is_strike() || p.soft.as_micros() == 0 || p.soft > p.loud {
                    return Err(StrikeError::Pulse { key });
                }
                if p.loud > max_pulse || p.loud > MAX_PULSE {
                    return Err(StrikeError::PulseTooLong { key });
                }
                if p.rebound < p.loud {
                    return Err(StrikeError::Rebound { key });
                }
            }
        }
        if self.pulses[..first].iter().any(Pulse::is_strike) {
            return Err(StrikeError::Pulse { key: 0 });
        }
        Ok(())
    }
}

impl Strikes {
    /// Whether notes strike `key` in group `g` (a lead or a damper has no notes of its own).
    fn plays_notes(&self, g: usize, key: u8) -> bool {
        match self.groups[g].notes {
            StrikeNotes::Sparse => self.map[g].contains(&key.wrapping_add(1)),
            StrikeNotes::Range(range, _) => (key - self.groups[g].first) < range.keys() as u8,
        }
    }

    /// The group `key` is an output of.
    pub fn group_of(&self, key: u8) -> Option<&StrikeGroup> {
        self.groups()
            .iter()
            .find(|g| (g.first..g.first + g.outputs).contains(&key))
    }

    /// Group `g`'s leads: each an output of the group, not the note's own, with a lead time
    /// above 0 and below the rebound of the output it leads.
    fn validate_leads(&self, g: usize, span: core::ops::Range<u8>) -> Result<(), StrikeError> {
        for (note, &lead) in self.leads[g].iter().enumerate() {
            let Some(lead) = lead.checked_sub(1) else {
                continue;
            };
            let own = self.map[g][note].checked_sub(1);
            let time = self.lead_times[lead as usize];
            let fits = own.is_some_and(|own| {
                !self.plays_notes(g, lead)
                    && time > Duration::ZERO
                    && time < self.pulse(own).rebound
            });
            if !span.contains(&lead) || !fits {
                return Err(StrikeError::Lead { note: note as u8 });
            }
        }
        Ok(())
    }
}

impl Default for Strikes {
    fn default() -> Self {
        Self::NONE
    }
}

/// Why a strike group has no output for a note.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StrikeMiss {
    /// No output of the kit plays it.
    Unmapped,
    /// Outside a pitched group's range, with the drop policy.
    Range,
}

/// Strike groups the interpreter cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StrikeError {
    /// More than [`MAX_STRIKE_GROUPS`].
    TooManyGroups,
    /// The guard is off: it times every pulse, so strike groups need it on.
    GuardOff,
    /// The keyboard's keys and the groups' outputs are not the layout's keys.
    Outputs {
        /// Keys of the keyboard and outputs of the groups.
        outputs: usize,
        /// Keys the boards drive.
        layout: usize,
    },
    /// A group's outputs do not follow the one before, it has none, or a pitched group's
    /// range is not as wide as its outputs.
    Span {
        /// The group, from 0.
        group: u8,
    },
    /// A sparse group's map names an output not its own.
    Map {
        /// The group, from 0.
        group: u8,
    },
    /// An output has no pulse, a zero one, or its loud pulse is shorter than its soft one
    /// (or a keyboard key has a pulse).
    Pulse {
        /// The key.
        key: u8,
    },
    /// An output's pulse is longer than the guard's `max_pulse` or [`MAX_PULSE`].
    PulseTooLong {
        /// The key.
        key: u8,
    },
    /// An output's rebound is shorter than its loud pulse.
    Rebound {
        /// The key.
        key: u8,
    },
    /// A note's lead is not an output of its group with no notes of its own, or has no lead
    /// time or one not below the rebound of the note's output.
    Lead {
        /// The note.
        note: u8,
    },
    /// An output's damper is not another output of its group with no notes of its own, has a
    /// damper of its own, or damps another output too.
    Damper {
        /// The key.
        key: u8,
    },
}

impl core::fmt::Display for StrikeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            StrikeError::TooManyGroups => {
                write!(f, "more than {MAX_STRIKE_GROUPS} strike groups")
            }
            StrikeError::GuardOff => {
                f.write_str("strike groups need the guard on: it ends every pulse")
            }
            StrikeError::Outputs { outputs, layout } => write!(
                f,
                "the keyboard and the strike groups have {outputs} outputs but the boards drive {layout}"
            ),
            StrikeError::Span { group } => write!(
                f,
                "strike group {group}: its outputs must follow the last group's, and a pitched group has one a note of its range"
            ),
            StrikeError::Map { group } => {
                write!(f, "strike group {group}: a note maps to another group's output")
            }
            StrikeError::Pulse { key } => write!(
                f,
                "key {key}: a strike's pulse must be above 0, the loud one at least the soft one"
            ),
            StrikeError::PulseTooLong { key } => write!(
                f,
                "key {key}: the pulse is longer than the guard's max_pulse (at most 250 ms)"
            ),
            StrikeError::Rebound { key } => {
                write!(f, "key {key}: the rebound is shorter than the loud pulse")
            }
            StrikeError::Lead { note } => write!(
                f,
                "note {note}: its lead must be an output of its group with no notes of its own, with a lead time above 0 and below the rebound of the note's output"
            ),
            StrikeError::Damper { key } => write!(
                f,
                "key {key}: its damper must be another output of its group, one with no notes, no damper of its own and no other output to damp"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: u8) -> Velocity {
        Velocity::new(x).unwrap()
    }

    #[test]
    fn a_pulse_grows_with_velocity_from_soft_to_loud() {
        let p = Pulse::DRUM;
        assert_eq!(p.length(v(1)), Duration::from_millis(8));
        assert_eq!(p.length(v(127)), Duration::from_millis(20));
        let mut last = Duration::ZERO;
        for x in 1..=127 {
            let l = p.length(v(x));
            assert!(l >= last && l >= p.soft && l <= p.loud, "velocity {x}");
            last = l;
        }
    }

    fn kit() -> Strikes {
        let mut s = Strikes {
            keyboard: false,
            ..Strikes::NONE
        };
        let drum = Pulse::DRUM;
        s.push_kit(ChannelMask(1 << 9), 61, &[(&[35, 36], drum), (&[38], drum)])
            .unwrap();
        let range = KeyRange::new(Note::from_bits(72), Note::from_bits(83)).unwrap();
        s.push_pitched(ChannelMask(1), 61, range, OutOfRange::Fold, drum)
            .unwrap();
        assert_eq!((s.groups[1].first, s.groups[1].outputs), (2, 12));
        s
    }

    #[test]
    fn notes_find_their_outputs_by_channel_and_map() {
        let s = kit();
        s.validate(61, 14, Duration::from_millis(100)).unwrap();
        let ch = |c| Channel::new(c).unwrap();
        let n = Note::from_bits;
        assert_eq!(s.find(ch(9), n(36)).unwrap().unwrap().key, 0);
        assert_eq!(s.find(ch(9), n(35)).unwrap().unwrap().key, 0);
        assert_eq!(s.find(ch(9), n(38)).unwrap().unwrap().key, 1);
        assert_eq!(s.find(ch(9), n(39)), Some(Err(StrikeMiss::Unmapped)));
        assert_eq!(s.find(ch(3), n(38)), None);
        let folded = s.find(ch(0), n(60)).unwrap().unwrap();
        assert_eq!((folded.key, folded.octaves), (2, 1));
    }

    /// A kit built in a `const` item, as an MCU's fixed robot builds it.
    const CONST_KIT: Strikes = Strikes::NONE
        .with_kit(
            ChannelMask(1 << 9),
            61,
            &[(&[35, 36], Pulse::DRUM), (&[38, 40], Pulse::DRUM)],
        )
        .with_kit(ChannelMask(1 << 8), 61, &[(&[60], Pulse::DRUM)]);

    #[test]
    fn a_kit_built_at_compile_time_is_the_one_push_kit_builds() {
        let mut s = Strikes::NONE;
        s.push_kit(
            ChannelMask(1 << 9),
            61,
            &[(&[35, 36], Pulse::DRUM), (&[38, 40], Pulse::DRUM)],
        )
        .unwrap();
        s.push_kit(ChannelMask(1 << 8), 61, &[(&[60], Pulse::DRUM)])
            .unwrap();
        assert_eq!(CONST_KIT, s);
        assert_eq!((s.groups[1].first, s.count), (63, 2));
        assert_eq!(CONST_KIT.map[0][40], 63);
        CONST_KIT
            .validate(61, 64, Duration::from_millis(100))
            .unwrap();
        // Its refusals, evaluated at compile time.
        const TOO_HIGH: Result<(), StrikeError> = {
            let mut s = Strikes::NONE;
            s.push_kit(ChannelMask(1), 0, &[(&[128], Pulse::DRUM)])
        };
        assert_eq!(TOO_HIGH, Err(StrikeError::Map { group: 0 }));
        const EMPTY: Result<(), StrikeError> = {
            let mut s = Strikes::NONE;
            s.push_kit(ChannelMask(1), 0, &[])
        };
        assert_eq!(EMPTY, Err(StrikeError::Span { group: 0 }));
        const FIFTH: Result<(), StrikeError> = {
            let mut s = CONST_KIT
                .with_kit(ChannelMask(1), 61, &[(&[1], Pulse::DRUM)])
                .with_kit(ChannelMask(1), 61, &[(&[2], Pulse::DRUM)]);
            s.push_kit(ChannelMask(1), 61, &[(&[3], Pulse::DRUM)])
        };
        assert_eq!(FIFTH, Err(StrikeError::TooManyGroups));
    }

    #[test]
    #[should_panic(expected = "push_kit refused")]
    fn with_kit_panics_on_a_kit_push_kit_refuses() {
        let _ = Strikes::NONE.with_kit(ChannelMask(1), 0, &[(&[200], Pulse::DRUM)]);
    }

    #[test]
    fn bad_groups_are_refused() {
        let max = Duration::from_millis(100);
        let mut s = kit();
        s.pulses[1].loud = Duration::from_millis(150);
        assert_eq!(
            s.validate(0, 14, max),
            Err(StrikeError::PulseTooLong { key: 1 })
        );
        let mut s = kit();
        s.map[0][40] = 5;
        assert_eq!(s.validate(0, 14, max), Err(StrikeError::Map { group: 0 }));
        let mut s = kit();
        s.pulses[3].rebound = Duration::from_millis(5);
        assert_eq!(s.validate(0, 14, max), Err(StrikeError::Rebound { key: 3 }));
        assert_eq!(
            kit().validate(0, 15, max),
            Err(StrikeError::Outputs {
                outputs: 14,
                layout: 15
            })
        );
    }
}
