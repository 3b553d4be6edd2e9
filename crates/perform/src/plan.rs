//! The streaming planner: score events in, timed sends out, each key early by its own delay.
//!
//! The planner reads the score as a stream and plans in score time with a bounded lookahead.
//! It keeps a queue of planned sends; a send leaves the queue only once nothing still unread
//! could change it: every send it plans for an event is at least [`Planner::lookahead_us`]
//! before that event's wall time, so once the next unread event is further away than that
//! from the head of the queue, the head is final. At a constant tempo the sends are therefore
//! exactly those of planning the whole song first ([`Planner::eager`]), and the tempo can
//! change at any moment ([`Planner::set_tempo`]) without planning the song again.
//!
//! # Rules
//!
//! The planner keeps a model of every key, mirroring the interpreter in `orch-core`: which
//! (channel, note) pairs hold it, when it struck, when it was let go.
//!
//! 1. **Compensation.** A Note-On is sent early by its key's press lead (the key's press delay
//!    and what the link to the robot adds); the Note-Off that lets a key go, by its release
//!    lead. With compensation off every message goes at its score time and nothing below
//!    applies.
//! 2. **One key's messages keep their order**: a message is never sent before an earlier one
//!    of the same key (equal times keep score order).
//! 3. **Notes, not only keys.** A Note-On on a key that is down joins it, with no strike and
//!    no constraint, when it is a unison (the key's strike has the same score time) or when
//!    `overlap = hold` and its own (channel, note) is not already on. Otherwise it is a
//!    re-strike: the planner sends Note-Offs for the key's holders early, `restrike_gap`
//!    before the new press, so the key lifts, rests and strikes on time. (The later Note-Offs
//!    of those notes in the score reach the robot as no-ops.)
//! 4. **The rest before a re-strike.** A press comes at least `restrike_gap` after the key's
//!    release: if it would come sooner, the release still waiting in the queue is **moved
//!    earlier**, but never before the key's previous message nor before its strike plus
//!    `min(min_press, the note's length)` (a late strike: its strike plus `min_press`).
//!    No press is let go before the key's shortest press that sounds (`min_hold`), however
//!    short its note: a 4 ms grace note still sounds.
//! 5. **Bounded lateness.** When a press cannot strike within `late_limit` of its score time
//!    even so, nothing is moved for it: if the robot can see it (the key still resting when
//!    the press arrives) the press is sent and the interpreter drops it as too fast; if only
//!    the planner can (the press had to wait behind the key's earlier messages), the planner
//!    drops it itself, as [`Planned::Dropped`] with [`DropReason::TooFast`].
//! 6. **Channel-wide controllers** (sustain 64, sostenuto 66, 120, 121, 123–127) keep their
//!    place among their channel's note messages: sent no earlier than the note messages
//!    before them in the score and, where that allows, no later than those after them.

use std::collections::BTreeMap;

mod wind;

use orch_core::{Channel, DropReason, Landing, Note, Overlap};
use orch_seq::WireBytes;

use crate::tempo::{Tempo, TimeMap};

/// A score note: the index of its Note-On among the score's Note-Ons.
pub type NoteId = u32;

/// One message of the score.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScoreEvent {
    /// Its time in the song, µs at the written tempo.
    pub score_us: u64,
    /// The message.
    pub bytes: WireBytes,
}

/// Where notes land, as the interpreter lands them: its keyboard's channels, key range and
/// fold policy, and its strike groups ([`Config::land`](orch_core::Config::land)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyMap(orch_core::Config<{ crate::MAX_BOARDS }>);

impl KeyMap {
    /// The notes of `config`'s robot.
    pub fn new(config: orch_core::Config<{ crate::MAX_BOARDS }>) -> Self {
        Self(config)
    }

    /// The key of `note` on `channel` (0..=15), if the robot plays it.
    pub fn land(&self, channel: u8, note: u8) -> Option<Landing> {
        let k = self.0.land(Channel::new(channel)?, Note::new(note)?).ok()?;
        Some(Landing {
            key: k.key,
            octaves: k.octaves,
        })
    }

    /// Whether `key` strikes: a pulse that ends by itself, its Note-Off ignored (see
    /// [`orch_core::strike`]).
    pub fn strikes(&self, key: usize) -> bool {
        u8::try_from(key).is_ok_and(|k| self.0.is_strike(k))
    }

    /// How long before its own output a note's lead output fires (an open hi-hat's lift), µs;
    /// 0 for a note with no lead. The interpreter strikes the note's output that much after
    /// the Note-On, so the planner sends it that much earlier.
    pub fn lead_us(&self, channel: u8, note: u8) -> u64 {
        let (Some(c), Some(n)) = (Channel::new(channel), Note::new(note)) else {
            return 0;
        };
        self.0
            .strikes
            .lead(c, n)
            .map_or(0, |(_, t)| t.as_micros() as u64)
    }

    /// Whether `key` is the fingered group's valve (every note of the group lands on it).
    pub fn wind(&self, key: usize) -> bool {
        self.0.wind.is_on() && key == usize::from(self.0.wind.valve())
    }

    /// Which note of a chord the fingered group plays.
    pub fn voice(&self) -> orch_core::Voice {
        self.0.wind.voice
    }

    /// The fingered group's settle and close times, µs.
    pub fn wind_times_us(&self) -> (i64, i64) {
        let w = &self.0.wind;
        (w.settle.as_micros() as i64, w.close.as_micros() as i64)
    }

    /// The longest lead time of any note beyond its press lead, µs: a strike's lead, or a
    /// wind note's settle and close.
    pub fn max_lead_us(&self) -> u64 {
        let times = self.0.strikes.lead_times.iter();
        let strike = times.map(|t| t.as_micros() as u64).max().unwrap_or(0);
        let (settle, close) = self.wind_times_us();
        let wind = if self.0.wind.is_on() {
            (settle + close) as u64
        } else {
            0
        };
        strike.max(wind)
    }
}

/// What the planner needs to know about the robot.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanRules {
    /// Where notes land.
    pub keys: KeyMap,
    /// Per key: how early to send its press, µs (its press delay and the link's time).
    pub press_lead_us: Vec<u64>,
    /// Per key that plays velocity (a PWM key): how early to send its press at each velocity
    /// (index 0..=127), µs, since a softer strike sounds later; empty (or a key past it) for
    /// the `press_lead_us` of every velocity.
    pub press_lead_by_velocity_us: Vec<Vec<u64>>,
    /// Per key: how early to send its release, µs.
    pub release_lead_us: Vec<u64>,
    /// Per key: the shortest press that sounds, µs. A press is never let go sooner, however
    /// short its note.
    pub min_hold_us: Vec<u64>,
    /// The guard's re-strike gap, µs (0 with the guard off).
    pub restrike_gap_us: u64,
    /// The guard's shortest strike, µs.
    pub min_press_us: u64,
    /// The guard's late limit, µs; `None` for none.
    pub late_limit_us: Option<u64>,
    /// What a second note on a key that is down does.
    pub overlap: Overlap,
    /// Send each key early by its lead (off: every message at its score time).
    pub compensation: bool,
    /// The longest a board write may queue on the bus behind the others', µs: kept free
    /// within the late limit.
    pub bus_margin_us: u64,
    /// How much further to read ahead than the leads need, µs: a link that paces a chord's
    /// messages as one burst needs to see the whole chord planned.
    pub extra_lookahead_us: u64,
}

/// What the planner counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlanStats {
    /// Releases moved earlier than their lead to give a re-strike its rest.
    pub releases_moved_early: u64,
    /// Note-Offs the planner added so a re-strike lands on time (rule 3).
    pub early_releases_added: u64,
    /// Presses sent later than their lead, behind the key's earlier messages.
    pub presses_held_back: u64,
    /// Notes the planner dropped as too fast (rule 5).
    pub dropped_too_fast: u64,
    /// Channel-wide controllers sent at other than their score time.
    pub controllers_moved: u64,
    /// The most sends waiting in the queue at once.
    pub peak_queue: usize,
}

/// One planned send.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Planned {
    /// Send `bytes` at wall time `at_us`.
    Send {
        /// Wall time, µs.
        at_us: i64,
        /// The message.
        bytes: WireBytes,
        /// The score note whose Note-On this is.
        note: Option<NoteId>,
        /// When the score wants it to act (to sound, for a Note-On), wall µs.
        score_at_us: i64,
        /// Added by the planner (rule 3), not in the score.
        added: bool,
    },
    /// A score note the planner does not send.
    Dropped {
        /// Its place among the sends: where its Note-On would have gone, wall µs.
        at_us: i64,
        /// Its wall time in the score.
        score_at_us: i64,
        /// Its channel (0..=15).
        channel: u8,
        /// Its note.
        note_number: u8,
        /// Its velocity.
        velocity: u8,
        /// The note.
        note: NoteId,
        /// Why.
        reason: DropReason,
    },
}

impl Planned {
    /// Its wall time: when to send it, or the score's time of a dropped note.
    pub fn at_us(&self) -> i64 {
        match self {
            Planned::Send { at_us, .. } => *at_us,
            Planned::Dropped { at_us, .. } => *at_us,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Strike {
    /// When the score wants it, wall µs.
    score_at: i64,
    /// When the key is predicted to go down.
    at: i64,
    /// It waited for the key's rest.
    late: bool,
}

#[derive(Clone, Debug, Default)]
struct KeyModel {
    holders: Vec<(u8, u8)>,
    strike: Option<Strike>,
    /// Send time of the key's latest planned message.
    last_send: Option<i64>,
    /// When the key was last let go (planned).
    released_at: Option<i64>,
    /// The queued message that lets the key go, and how early it may move.
    release: Option<((i64, u64), i64)>,
    /// Messages of the key queued after that release that do nothing to it (Note-Offs of
    /// notes no longer on, presses too fast to strike): they move with it, so the key's order
    /// holds.
    trailing: Vec<(i64, u64)>,
}

type QueueKey = (i64, u64);

/// The streaming planner. See the [module notes](self).
#[derive(Debug)]
pub struct Planner<S: Iterator<Item = ScoreEvent>> {
    source: std::iter::Peekable<S>,
    rules: PlanRules,
    map: TimeMap,
    lookahead: i64,
    queue: BTreeMap<QueueKey, Planned>,
    seq: u64,
    keys: Vec<KeyModel>,
    /// Per note number: the channels on which it is on (the interpreter's record, mirrored).
    on: [u16; 128],
    /// Per (channel, note): when its latest Note-On was sent. Its Note-Off never goes sooner
    /// than the key's shortest sounding press after it, whatever the model says of it, so a
    /// note the robot strikes where the model expected a join or a drop still sounds.
    on_sent: Vec<i64>,
    /// Per channel: the latest send of a mapped note message, and the last channel-wide
    /// controller still movable (its queue key and its lower bound).
    channel_last: [Option<i64>; 16],
    channel_cc: [Option<(QueueKey, i64)>; 16],
    next_note: NoteId,
    /// Channels whose sustain or sostenuto pedal the score has used: a jump sets their pedals
    /// to the score's state at the target (up if it has none there).
    pedals: u16,
    eager: bool,
    stats: PlanStats,
    /// The fingered group's Note-Offs and valve.
    wind: wind::WindPlan,
}

/// A score note a jump passed over or left unsent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Skipped {
    /// The note (its index among the score's Note-Ons).
    pub note: NoteId,
    /// Its channel (0..=15).
    pub channel: u8,
    /// Its note number.
    pub note_number: u8,
    /// Its velocity (1..=127).
    pub velocity: u8,
    /// When it would have sounded, wall µs, by the time map before the jump.
    pub score_at_us: i64,
}

/// What a jump ([`Planner::jump`]) left behind.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Jumped {
    /// Notes read and planned before the jump but not sent (nor dropped) yet, in queue order.
    pub unsent: Vec<Skipped>,
    /// Notes before the target that the planner had not read before the jump (a jump forward
    /// passes over them), in score order.
    pub passed: Vec<Skipped>,
}

impl PlanRules {
    /// How early to send a press of `key` at `velocity`, µs.
    pub fn press_lead(&self, key: usize, velocity: u8) -> u64 {
        self.press_lead_by_velocity_us
            .get(key)
            .and_then(|l| l.get(usize::from(velocity)))
            .or_else(|| self.press_lead_us.get(key))
            .copied()
            .unwrap_or(0)
    }

    /// The longest press lead of any key at any velocity, µs.
    pub fn max_press_lead(&self) -> u64 {
        let by_velocity = self.press_lead_by_velocity_us.iter().flatten();
        self.press_lead_us
            .iter()
            .chain(by_velocity)
            .copied()
            .max()
            .unwrap_or(0)
    }
}

impl<S: Iterator<Item = ScoreEvent>> Planner<S> {
    /// A planner of `source` (in score order) for a robot as `rules` say, with score time 0
    /// at wall time `start_us + lookahead` (so no send falls before `start_us`).
    pub fn new(source: S, rules: PlanRules, start_us: i64, tempo: Tempo) -> Self {
        let keys = rules.press_lead_us.len().max(rules.release_lead_us.len());
        let lead = |v: &[u64]| v.iter().copied().max().unwrap_or(0);
        let lookahead = if rules.compensation {
            (rules.max_press_lead() + rules.keys.max_lead_us() + rules.restrike_gap_us)
                .max(lead(&rules.release_lead_us))
                + rules.extra_lookahead_us
        } else {
            0
        } as i64;
        Self {
            source: source.peekable(),
            map: TimeMap::new(start_us + lookahead, tempo),
            lookahead,
            rules,
            queue: BTreeMap::new(),
            seq: 0,
            keys: vec![KeyModel::default(); keys],
            on: [0; 128],
            on_sent: vec![i64::MIN; 16 * 128],
            channel_last: [None; 16],
            channel_cc: [None; 16],
            next_note: 0,
            pedals: 0,
            eager: false,
            stats: PlanStats::default(),
            wind: Default::default(),
        }
    }

    /// Starts at wall time `start_us` instead of the one [`new`](Self::new) was given (before
    /// anything is planned): score time 0 plays the lookahead after it.
    pub fn starting(mut self, start_us: i64) -> Self {
        self.map = TimeMap::new(start_us + self.lookahead, self.map.tempo());
        self
    }

    /// Plans the whole song before the first send leaves: the reference the streaming planner
    /// must equal at a constant tempo.
    pub fn eager(mut self) -> Self {
        self.eager = true;
        self
    }

    /// How far ahead of the present the planner reads the score, in wall µs: the longest
    /// press lead plus the re-strike gap (or the longest release lead, if longer).
    pub fn lookahead_us(&self) -> i64 {
        self.lookahead
    }

    /// How long after a jump its target plays, wall µs: the lookahead, at least the re-strike
    /// gap (so that the first notes after the target strike on time, with every key up).
    pub fn jump_lead_us(&self) -> i64 {
        self.lookahead.max(self.rules.restrike_gap_us as i64)
    }

    /// The score ↔ wall time map.
    pub fn time_map(&self) -> &TimeMap {
        &self.map
    }

    /// What the planner counted so far.
    pub fn stats(&self) -> PlanStats {
        self.stats
    }

    /// Score notes read so far.
    pub fn notes_read(&self) -> u32 {
        self.next_note
    }

    /// From wall time `now_us` on, play at `tempo`. Score time stays continuous; sends still
    /// in the queue keep their offset from their own score time (so compensation stays
    /// right), and never move before `now_us`.
    pub fn set_tempo(&mut self, now_us: i64, tempo: Tempo) {
        let old = self.map;
        self.map.change(now_us, tempo);
        self.remap(old, now_us, now_us);
    }

    /// Paused at wall time `paused_us` (nothing sent since), going on at `now_us`: everything
    /// planned from `paused_us` on moves later by the pause, at the same tempo.
    pub fn resume(&mut self, paused_us: i64, now_us: i64) {
        let old = self.map;
        self.map.resume(paused_us, now_us);
        self.remap(old, paused_us, now_us);
    }

    /// Jumps to score time `target_us`, from wall time `now_us` on, reading the score again
    /// from `source` (the same score from its start; it is read up to the target without
    /// planning anything). Every key is taken to be released at `now_us` (the performer lets
    /// every key go there); the queue is emptied and returned as [`Jumped::unsent`]. The target
    /// plays at `now_us` plus the lookahead (at least the re-strike gap), at the same tempo,
    /// so the first notes after it strike on time. The channels' state at the target is
    /// chased: the last program, controllers (0–119, after any Reset All Controllers), channel
    /// pressure and pitch bend of each channel before the target are sent at `now_us`, and
    /// the pedals (64, 66) of every channel that has used one are set to their state there
    /// (up if none). Notes sounding across the target (their Note-On before it) are not
    /// restarted. Note numbering goes on from the score's own: the first note at or after the
    /// target keeps its index among the score's Note-Ons ([`notes_read`](Self::notes_read)
    /// after the jump).
    pub fn jump(&mut self, source: S, now_us: i64, target_us: u64) -> Jumped {
        let read_before = self.next_note;
        let mut jumped = Jumped::default();
        for p in std::mem::take(&mut self.queue).into_values() {
            match p {
                Planned::Send {
                    bytes,
                    note: Some(id),
                    score_at_us,
                    ..
                } => {
                    if let Some((ch, n, v)) = bytes.note_on() {
                        jumped.unsent.push(Skipped {
                            note: id,
                            channel: ch,
                            note_number: n,
                            velocity: v,
                            score_at_us,
                        });
                    }
                }
                Planned::Dropped {
                    score_at_us,
                    channel,
                    note_number,
                    velocity,
                    note,
                    ..
                } => jumped.unsent.push(Skipped {
                    note,
                    channel,
                    note_number,
                    velocity,
                    score_at_us,
                }),
                Planned::Send { .. } => {}
            }
        }
        let keys = self.keys.len();
        self.keys = vec![
            KeyModel {
                last_send: Some(now_us),
                released_at: Some(now_us),
                ..KeyModel::default()
            };
            keys
        ];
        self.on = [0; 128];
        self.on_sent.fill(i64::MIN);
        self.channel_last = [None; 16];
        self.channel_cc = [None; 16];
        // Read up to the target: count the notes, keep each channel's latest state.
        let old = self.map;
        let mut state: BTreeMap<(u8, u8, u8), WireBytes> = BTreeMap::new();
        self.source = source.peekable();
        self.next_note = 0;
        while let Some(e) = self.source.next_if(|e| e.score_us < target_us) {
            if let Some((ch, n, v)) = e.bytes.note_on() {
                if self.next_note >= read_before {
                    jumped.passed.push(Skipped {
                        note: self.next_note,
                        channel: ch,
                        note_number: n,
                        velocity: v,
                        score_at_us: old.wall(e.score_us),
                    });
                }
                self.next_note += 1;
                continue;
            }
            let Some(ch) = e.bytes.channel() else {
                continue;
            };
            match (e.bytes.status() & 0xF0, e.bytes.get(1).copied()) {
                (0xB0, Some(121)) => state.retain(|&(c, kind, _), _| c != ch || kind == 0xC0),
                (0xB0, Some(c @ 0..=119)) => {
                    if matches!(c, 64 | 66) {
                        self.pedals |= 1 << ch;
                    }
                    state.insert((ch, 0xB0, c), e.bytes);
                }
                (kind @ (0xC0 | 0xD0 | 0xE0), _) => {
                    state.insert((ch, kind, 0), e.bytes);
                }
                _ => {}
            }
        }
        for ch in 0..16u8 {
            if self.pedals & 1 << ch != 0 {
                for pedal in [64, 66] {
                    state
                        .entry((ch, 0xB0, pedal))
                        .or_insert_with(|| WireBytes::new(&[0xB0 | ch, pedal, 0]));
                }
            }
        }
        // Program first, then controllers, pressure and bend, channel by channel.
        let mut chased: Vec<_> = state.into_iter().collect();
        chased.sort_by_key(|&((ch, kind, n), _)| (ch, kind != 0xC0, kind, n));
        for (_, bytes) in chased {
            self.send(now_us, bytes, None, now_us);
        }
        self.map.jump(now_us + self.jump_lead_us(), target_us);
        jumped
    }

    /// The queue and the key models after the map changed from `old`: times from `from_us`
    /// on follow the map, sends never before `now_us`.
    fn remap(&mut self, old: TimeMap, from_us: i64, now_us: i64) {
        let moved: Vec<(QueueKey, Planned)> = std::mem::take(&mut self.queue).into_iter().collect();
        let shift = |t: i64, score_at: i64| -> i64 {
            let score = old.score(score_at);
            let new_at = self.map.wall(score);
            (new_at - (score_at - t)).max(now_us)
        };
        let mut fixed = BTreeMap::new();
        let mut renamed = std::collections::HashMap::new();
        for ((_, seq), mut p) in moved {
            let new_t = match &mut p {
                Planned::Send {
                    at_us, score_at_us, ..
                } => {
                    let n = shift(*at_us, *score_at_us);
                    *score_at_us = self.map.wall(old.score(*score_at_us));
                    *at_us = n;
                    n
                }
                Planned::Dropped {
                    at_us, score_at_us, ..
                } => {
                    let n = shift(*at_us, *score_at_us);
                    *score_at_us = self.map.wall(old.score(*score_at_us));
                    *at_us = n;
                    n
                }
            };
            renamed.insert(seq, new_t);
            fixed.insert((new_t, seq), p);
        }
        self.queue = fixed;
        // The movable handles follow their sends; bounds and model times follow the map.
        let map = self.map;
        let remap = |t: i64| {
            if t < from_us {
                t
            } else {
                map.wall(old.score(t))
            }
        };
        for k in &mut self.keys {
            k.release = k
                .release
                .and_then(|((_, seq), floor)| Some(((*renamed.get(&seq)?, seq), remap(floor))));
            k.trailing = k
                .trailing
                .iter()
                .filter_map(|&(_, seq)| Some((*renamed.get(&seq)?, seq)))
                .collect();
            k.last_send = k.last_send.map(remap);
            k.released_at = k.released_at.map(remap);
            if let Some(st) = &mut k.strike {
                st.at = remap(st.at);
                st.score_at = remap(st.score_at);
            }
        }
        for c in &mut self.channel_cc {
            *c = c.and_then(|((_, seq), lo)| Some(((*renamed.get(&seq)?, seq), remap(lo))));
        }
        for l in &mut self.channel_last {
            *l = l.map(remap);
        }
        self.wind_remap(&renamed, remap);
    }

    /// The wall time of the next send, once it is final; `None` when the song is over.
    pub fn peek_time(&mut self) -> Option<i64> {
        if self.eager {
            while let Some(e) = self.source.next() {
                self.plan(e);
            }
        }
        loop {
            let frontier = match self.source.peek() {
                Some(e) => self.map.wall(e.score_us) - self.lookahead,
                None => i64::MAX,
            };
            if let Some((&(t, _), _)) = self.queue.first_key_value() {
                if t < frontier {
                    return Some(t);
                }
            }
            let e = self.source.next()?;
            self.plan(e);
        }
    }

    /// The final sends at the head of the queue, in order (at least the head, if any): what
    /// no unread event can change any more.
    pub fn final_sends(&mut self) -> Vec<&Planned> {
        if self.peek_time().is_none() {
            return Vec::new();
        }
        let frontier = match self.source.peek() {
            Some(e) if !self.eager => self.map.wall(e.score_us) - self.lookahead,
            _ => i64::MAX,
        };
        self.queue
            .iter()
            .take_while(|((t, _), _)| *t < frontier)
            .map(|(_, p)| p)
            .collect()
    }

    /// The next send, once it is final; `None` when the song is over.
    pub fn next_planned(&mut self) -> Option<Planned> {
        self.peek_time()?;
        self.queue.pop_first().map(|(_, p)| p)
    }

    /// The wall time at which the score plays `score_us`.
    pub fn wall(&self, score_us: u64) -> i64 {
        self.map.wall(score_us)
    }

    fn push(&mut self, p: Planned) -> QueueKey {
        let key = (p.at_us(), self.seq);
        self.seq += 1;
        self.queue.insert(key, p);
        self.stats.peak_queue = self.stats.peak_queue.max(self.queue.len());
        key
    }

    fn send(&mut self, at: i64, bytes: WireBytes, note: Option<NoteId>, score_at: i64) -> QueueKey {
        if let Some((ch, n, _)) = bytes.note_on() {
            self.on_sent[usize::from(ch) * 128 + usize::from(n)] = at;
        }
        self.push(Planned::Send {
            at_us: at,
            bytes,
            note,
            score_at_us: score_at,
            added: false,
        })
    }

    fn plan(&mut self, e: ScoreEvent) {
        let w = self.map.wall(e.score_us);
        let note_on = e.bytes.note_on();
        let id = note_on.map(|_| {
            let id = self.next_note;
            self.next_note += 1;
            id
        });
        if !self.rules.compensation {
            self.send(w, e.bytes, id, w);
            return;
        }
        if let Some((ch, n, _)) = note_on {
            self.note_on(ch, n, w, e.bytes, id.unwrap_or(0));
        } else if let Some((ch, n)) = e.bytes.note_off() {
            self.note_off(ch, n, w, e.bytes);
        } else if let Some((ch, c, _)) = e.bytes.control_change() {
            if matches!(c, 64 | 66) {
                self.pedals |= 1 << ch;
            }
            if matches!(c, 64 | 66 | 120 | 121 | 123..=127) {
                let lo = self.channel_last[usize::from(ch)].unwrap_or(i64::MIN);
                let at = w.max(lo);
                if at != w {
                    self.stats.controllers_moved += 1;
                }
                let q = self.send(at, e.bytes, None, w);
                self.channel_cc[usize::from(ch)] = Some((q, lo));
            } else {
                self.send(w, e.bytes, None, w);
            }
        } else {
            self.send(w, e.bytes, None, w);
        }
    }

    fn min_hold(&self, key: usize) -> i64 {
        self.rules.min_hold_us.get(key).copied().unwrap_or(0) as i64
    }

    /// Whether a strike this late (µs after its score's press time) is within the late
    /// limit, keeping room for the bus: a strike the interpreter makes at the limit still has
    /// to queue behind the other boards' writes.
    fn late_ok(&self, late: i64) -> bool {
        self.rules
            .late_limit_us
            .is_none_or(|l| late <= l as i64 - self.rules.bus_margin_us as i64)
    }

    /// Whether the interpreter itself drops a press that arrives `wait` before its key may
    /// strike.
    fn robot_drops(&self, wait: i64) -> bool {
        self.rules.late_limit_us.is_some_and(|l| wait > l as i64)
    }

    /// A note message on channel `ch` is to be sent at `at`: a channel-wide controller after
    /// it in the queue (before it in the score) moves earlier to stay ahead of it, down to its
    /// own bound; returns the earliest the note message may go.
    fn after_controller(&mut self, ch: u8, at: i64) -> i64 {
        let c = usize::from(ch);
        let Some((q, lo)) = self.channel_cc[c] else {
            return at;
        };
        if q.0 <= at {
            return at;
        }
        let new_t = at.max(lo);
        if let Some(p) = self.queue.remove(&q) {
            let p = match p {
                Planned::Send {
                    bytes,
                    note,
                    score_at_us,
                    added,
                    ..
                } => Planned::Send {
                    at_us: new_t,
                    bytes,
                    note,
                    score_at_us,
                    added,
                },
                d => d,
            };
            let nq = (new_t, q.1);
            self.queue.insert(nq, p);
            self.channel_cc[c] = Some((nq, lo));
        }
        at.max(new_t)
    }

    fn mark(&mut self, ch: u8, key: usize, at: i64) {
        let c = usize::from(ch);
        self.channel_last[c] = Some(self.channel_last[c].map_or(at, |l| l.max(at)));
        self.keys[key].last_send = Some(at);
    }

    fn note_on(&mut self, ch: u8, n: u8, w: i64, bytes: WireBytes, id: NoteId) {
        let Some(land) = self.rules.keys.land(ch, n) else {
            self.send(w, bytes, Some(id), w);
            return;
        };
        let k = usize::from(land.key);
        if self.rules.keys.wind(k) {
            self.wind_on(ch, k, w, bytes, id);
            return;
        }
        let velocity = bytes.note_on().map_or(0, |(_, _, v)| v);
        let lead = self.rules.press_lead(k, velocity) as i64;
        if self.rules.keys.strikes(k) {
            // A strike: sent early by its flight, and by its lead's time if it has one (the
            // interpreter fires the lead, then the strike that much later); the interpreter
            // keeps the beater's rebound (a strike too soon waits, joins or is dropped as too
            // fast there).
            let lead = lead + self.rules.keys.lead_us(ch, n) as i64;
            let at = self.after_controller(ch, w - lead);
            self.send(at, bytes, Some(id), w);
            self.mark(ch, k, at);
            return;
        }
        let gap = self.rules.restrike_gap_us as i64;
        let min_press = self.rules.min_press_us as i64;
        let p_des = w - lead;
        let repeated = self.on[usize::from(n)] & (1 << ch) != 0;
        let model = &self.keys[k];
        let last = model.last_send.unwrap_or(i64::MIN);
        if !model.holders.is_empty() {
            // As the interpreter judges it: a note arriving while the key waits to strike, or
            // less than `min_press` after it struck, joins the strike.
            let arrival = p_des.max(last);
            let with_strike = model
                .strike
                .is_some_and(|s| s.score_at == w || arrival < s.at + min_press);
            if with_strike || (!repeated && self.rules.overlap == Overlap::Hold) {
                // Joins the key: no strike, nothing to move.
                let at = self.after_controller(ch, p_des.max(last));
                self.send(at, bytes, Some(id), w);
                if !repeated {
                    self.keys[k].holders.push((ch, n));
                    self.on[usize::from(n)] |= 1 << ch;
                }
                self.mark(ch, k, at);
                return;
            }
            // A re-strike: let the key go early enough to rest.
            let st = model.strike.expect("a held key has a strike");
            let hold = if st.late {
                min_press
            } else {
                min_press.min(w - st.score_at).max(0)
            }
            .max(self.min_hold(k));
            let floor = last.max(st.at + hold);
            let r = (p_des - gap).max(floor);
            let strike_at = p_des.max(r + gap);
            if !self.late_ok(strike_at - p_des) {
                // Too fast: nothing moves for it. Arriving on a key that is down, it would
                // have to wait a whole gap.
                self.too_fast(ch, n, k, p_des.max(last), p_des, gap, w, bytes, id);
                return;
            }
            let holders = std::mem::take(&mut self.keys[k].holders);
            for (hc, hn) in holders {
                self.on[usize::from(hn)] &= !(1 << hc);
                self.push(Planned::Send {
                    at_us: r,
                    bytes: WireBytes::new(&[0x80 | hc, hn, 0]),
                    note: None,
                    score_at_us: r,
                    added: true,
                });
                self.stats.early_releases_added += 1;
                self.mark(hc, k, r);
            }
            let m = &mut self.keys[k];
            m.strike = None;
            m.released_at = Some(r);
            m.release = None;
            m.trailing.clear();
        } else if let Some((q, floor)) = model.release {
            // Rule 4: the release waiting in the queue moves earlier if the press needs it.
            if p_des - q.0 < gap {
                let r = (p_des - gap).max(floor);
                let strike_at = p_des.max(r + gap);
                if r < q.0 && self.late_ok(strike_at - p_des) {
                    let nq = self.move_to(q, r);
                    for t in std::mem::take(&mut self.keys[k].trailing) {
                        self.move_to(t, r);
                    }
                    let m = &mut self.keys[k];
                    m.released_at = Some(r);
                    m.release = Some((nq, floor));
                    m.last_send = Some(r);
                    self.stats.releases_moved_early += 1;
                }
            }
        }
        // A strike on a free key.
        let m = &self.keys[k];
        let last = m.last_send.unwrap_or(i64::MIN);
        let free = m.released_at.map_or(i64::MIN, |r| r + gap);
        let at = self.after_controller(ch, p_des.max(last));
        let strike_at = at.max(free);
        if !self.late_ok(strike_at - p_des) {
            self.too_fast(ch, n, k, at, p_des, strike_at - at, w, bytes, id);
            return;
        }
        if at > p_des {
            self.stats.presses_held_back += 1;
        }
        self.send(at, bytes, Some(id), w);
        self.mark(ch, k, at);
        self.on[usize::from(n)] |= 1 << ch;
        let m = &mut self.keys[k];
        m.holders.push((ch, n));
        m.strike = Some(Strike {
            score_at: w,
            at: strike_at,
            late: strike_at > at,
        });
        m.release = None;
        m.trailing.clear();
    }

    /// A press that cannot strike within the late limit. When the interpreter will see that
    /// itself (sent on time, it finds its key busy for longer than the limit: `wait`), it is
    /// sent and the interpreter drops it; otherwise (held back behind the key's earlier
    /// messages, or late by less than the limit plus the bus margin) only the planner knows,
    /// and drops it.
    #[allow(clippy::too_many_arguments)]
    fn too_fast(
        &mut self,
        ch: u8,
        n: u8,
        k: usize,
        at: i64,
        p_des: i64,
        wait: i64,
        w: i64,
        bytes: WireBytes,
        id: NoteId,
    ) {
        let m = &self.keys[k];
        let idle = m.holders.is_empty() && m.release.is_some();
        let q = if at > p_des || !self.robot_drops(wait) {
            self.stats.dropped_too_fast += 1;
            self.push(Planned::Dropped {
                at_us: at,
                score_at_us: w,
                channel: ch,
                note_number: n,
                velocity: bytes.note_on().map_or(0, |(_, _, v)| v),
                note: id,
                reason: DropReason::TooFast,
            })
        } else {
            let q = self.send(at, bytes, Some(id), w);
            self.mark(ch, k, at);
            q
        };
        if idle {
            // It follows the key's release in the key's order: if the release moves, it moves.
            self.keys[k].trailing.push(q);
        }
    }

    fn note_off(&mut self, ch: u8, n: u8, w: i64, bytes: WireBytes) {
        let Some(land) = self.rules.keys.land(ch, n) else {
            self.send(w, bytes, None, w);
            return;
        };
        let k = usize::from(land.key);
        if self.rules.keys.wind(k) {
            self.wind_off(ch, w, bytes);
            return;
        }
        if self.rules.keys.strikes(k) {
            // A strike's Note-Off does nothing: sent at its time.
            let at = self.after_controller(ch, w);
            self.send(at, bytes, None, w);
            return;
        }
        let lead = self.rules.release_lead_us.get(k).copied().unwrap_or(0) as i64;
        let min_hold_k = self.rules.min_hold_us.get(k).copied().unwrap_or(0) as i64;
        let own_on = self.on_sent[usize::from(ch) * 128 + usize::from(n)];
        let r_des = (w - lead).max(own_on.saturating_add(min_hold_k));
        let last = self.keys[k].last_send.unwrap_or(i64::MIN);
        let was_on = self.on[usize::from(n)] & (1 << ch) != 0;
        self.on[usize::from(n)] &= !(1 << ch);
        let m = &mut self.keys[k];
        if was_on {
            m.holders.retain(|&h| h != (ch, n));
        }
        if !was_on || !m.holders.is_empty() {
            // No effect on the key: keep its place in the key's order.
            let idle = m.holders.is_empty() && m.release.is_some();
            let at = self.after_controller(ch, r_des.max(last));
            let q = self.send(at, bytes, None, w);
            self.mark(ch, k, at);
            if idle {
                self.keys[k].trailing.push(q);
            }
            return;
        }
        let min_press = self.rules.min_press_us as i64;
        let min_hold = self.rules.min_hold_us.get(k).copied().unwrap_or(0) as i64;
        let floor = match m.strike {
            Some(st) if st.late => last.max(st.at + min_press.max(min_hold)),
            Some(st) => last.max(st.at + min_press.min(w - st.score_at).max(min_hold)),
            None => last,
        };
        let at = self.after_controller(ch, r_des.max(floor));
        let q = self.send(at, bytes, None, w);
        self.mark(ch, k, at);
        let m = &mut self.keys[k];
        m.strike = None;
        m.released_at = Some(at);
        m.release = Some((q, floor));
        m.trailing.clear();
    }

    /// Moves the queued send `q` to wall time `t`; returns its new queue key.
    fn move_to(&mut self, q: QueueKey, t: i64) -> QueueKey {
        let nq = (t, q.1);
        if let Some(mut p) = self.queue.remove(&q) {
            match &mut p {
                Planned::Send { at_us, .. } | Planned::Dropped { at_us, .. } => *at_us = t,
            }
            self.queue.insert(nq, p);
        }
        nq
    }
}
