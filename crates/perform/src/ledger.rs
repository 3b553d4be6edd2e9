//! The account of every note: what the interpreter decided, and when its strike sounded.
//!
//! [`Ledger`] takes, in order, the Note-Ons delivered to a robot (with their score note),
//! the interpreter's [`NoteEvent`]s, and at the end the virtual robot's presses. Each note
//! gets exactly one [`Outcome`]. Nothing is guessed from key phases: the interpreter says
//! whether a note struck, joined or was dropped and why, and the robot says when the strike
//! sounded.

use std::collections::VecDeque;

use orch_core::{DropReason, Landing, NoteEvent};
use orch_sim::Press;

use crate::plan::NoteId;

/// How far from its score time a strike may sound and still be on time: 1 ms.
pub const ON_TIME_US: i64 = 1_000;

/// What became of one note.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// Its own strike sounded within 1 ms of its score time.
    OnTime {
        /// Sound − score, ms.
        error_ms: f64,
    },
    /// Its own strike sounded later than that.
    Late {
        /// Sound − score, ms.
        by_ms: f64,
    },
    /// Its own strike sounded earlier than 1 ms before its score time.
    Early {
        /// Score − sound, ms.
        by_ms: f64,
    },
    /// Struck together with another note on the same key at the same score time (a doubling,
    /// a fold collision): that note's strike is its sound.
    Unison,
    /// The key was already down for another note: no strike of its own.
    Joined,
    /// Not played.
    Dropped(DropReason),
    /// It struck, but the robot made no sound for it (a press too short to sound).
    Unmatched,
}

impl Outcome {
    /// The outcome's name in reports.
    pub fn name(&self) -> &'static str {
        match self {
            Outcome::OnTime { .. } => "on_time",
            Outcome::Late { .. } => "late",
            Outcome::Early { .. } => "early",
            Outcome::Unison => "unison",
            Outcome::Joined => "joined",
            Outcome::Dropped(r) => r.name(),
            Outcome::Unmatched => "unmatched",
        }
    }
}

/// One score note and what became of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoteRecord {
    /// Its place among the score's Note-Ons.
    pub id: NoteId,
    /// Its channel (0..=15) and note.
    pub channel: u8,
    /// The note.
    pub note: u8,
    /// When the score wants it to sound, wall µs.
    pub score_at_us: i64,
    /// Where it landed, if it has a key.
    pub landing: Option<Landing>,
    /// What became of it.
    pub outcome: Outcome,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Unsent,
    Waiting,
    Struck { key: u8, at_us: u64 },
    Done(Outcome),
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    channel: u8,
    note: u8,
    score_at: i64,
    landing: Option<Landing>,
    state: State,
}

/// The account. See the [module notes](self).
#[derive(Debug, Default)]
pub struct Ledger {
    notes: Vec<Entry>,
    /// Note-Ons delivered whose first event has not come yet.
    in_flight: VecDeque<NoteId>,
    /// Per key: the note whose strike it is, and the note waiting to strike.
    owner: Vec<Option<NoteId>>,
    waiting: Vec<Option<NoteId>>,
    /// Per key: strikes in order (note, instant).
    strikes: Vec<Vec<(NoteId, u64)>>,
    restrikes_waited: u64,
}

impl Ledger {
    /// An account for a robot with `keys` keys.
    pub fn new(keys: usize) -> Self {
        Self {
            owner: vec![None; keys],
            waiting: vec![None; keys],
            strikes: vec![Vec::new(); keys],
            ..Self::default()
        }
    }

    fn entry(&mut self, id: NoteId) -> &mut Entry {
        let i = id as usize;
        while self.notes.len() <= i {
            self.notes.push(Entry {
                channel: 0,
                note: 0,
                score_at: 0,
                landing: None,
                state: State::Unsent,
            });
        }
        &mut self.notes[i]
    }

    /// Score note `id` (channel, note) wants to sound at `score_at_us`.
    pub fn score(&mut self, id: NoteId, channel: u8, note: u8, score_at_us: i64) {
        let e = self.entry(id);
        e.channel = channel;
        e.note = note;
        e.score_at = score_at_us;
    }

    /// Its Note-On was delivered to the robot (its first event comes when the robot decodes it).
    pub fn delivered(&mut self, id: NoteId) {
        self.in_flight.push_back(id);
    }

    /// The planner dropped it.
    pub fn dropped(&mut self, id: NoteId, reason: DropReason) {
        self.entry(id).state = State::Done(Outcome::Dropped(reason));
    }

    /// Re-strikes that waited for their key's rest.
    pub fn restrikes_waited(&self) -> u64 {
        self.restrikes_waited
    }

    /// The interpreter decided `event` at `t_us`.
    pub fn decided(&mut self, t_us: u64, event: NoteEvent) {
        match event {
            NoteEvent::Struck { at, .. } => {
                let Some(id) = self.in_flight.pop_front() else {
                    return;
                };
                self.entry(id).landing = Some(at);
                self.strike(id, at.key, t_us);
            }
            NoteEvent::Waiting { at, .. } => {
                let Some(id) = self.in_flight.pop_front() else {
                    return;
                };
                let e = self.entry(id);
                e.landing = Some(at);
                e.state = State::Waiting;
                if let Some(w) = self.waiting.get_mut(at.key as usize) {
                    *w = Some(id);
                }
            }
            NoteEvent::Joined {
                at, with_strike, ..
            } => {
                let Some(id) = self.in_flight.pop_front() else {
                    return;
                };
                let k = at.key as usize;
                let owner = self.waiting[k].or(self.owner[k]);
                let score_at = self.entry(id).score_at;
                // A unison: the strike it joins is for the same score instant. (With no score,
                // as for live input, the interpreter's own judgement: it joined the strike.)
                let unison = match owner.map(|o| self.notes[o as usize].score_at) {
                    Some(s) => s == score_at,
                    None => with_strike,
                };
                let e = self.entry(id);
                e.landing = Some(at);
                e.state = State::Done(if unison {
                    Outcome::Unison
                } else {
                    Outcome::Joined
                });
            }
            NoteEvent::Dropped { at, reason, .. } => {
                let Some(id) = self.in_flight.pop_front() else {
                    return;
                };
                let e = self.entry(id);
                e.landing = at;
                e.state = State::Done(Outcome::Dropped(reason));
            }
            NoteEvent::WaitOver { key } => {
                if let Some(id) = self.waiting.get_mut(key as usize).and_then(Option::take) {
                    self.restrikes_waited += 1;
                    self.strike(id, key, t_us);
                }
            }
            NoteEvent::WaitEnded { key, reason } => {
                if let Some(id) = self.waiting.get_mut(key as usize).and_then(Option::take) {
                    self.entry(id).state = State::Done(Outcome::Dropped(reason));
                }
            }
        }
    }

    fn strike(&mut self, id: NoteId, key: u8, t_us: u64) {
        self.entry(id).state = State::Struck { key, at_us: t_us };
        if let Some(o) = self.owner.get_mut(key as usize) {
            *o = Some(id);
        }
        if let Some(s) = self.strikes.get_mut(key as usize) {
            s.push((id, t_us));
        }
    }

    /// Closes the account with the virtual robot's presses: each strike is matched to the
    /// first press of its key that began at or after it and before the key's next strike.
    /// Notes never delivered, or delivered but not yet decoded, are stopped. `total` is the
    /// number of notes in the score.
    pub fn close(mut self, presses: &[Press], total: usize) -> Vec<NoteRecord> {
        if total > 0 {
            self.entry(total as u32 - 1);
        }
        let mut by_key: Vec<Vec<&Press>> = vec![Vec::new(); self.strikes.len()];
        for p in presses {
            if let Some(v) = by_key.get_mut(p.key as usize) {
                v.push(p);
            }
        }
        for v in &mut by_key {
            v.sort_by_key(|p| p.pin_high);
        }
        for (key, strikes) in self.strikes.iter().enumerate() {
            let presses = &by_key[key];
            let mut next = 0;
            for (i, &(id, at)) in strikes.iter().enumerate() {
                let before = strikes.get(i + 1).map_or(u64::MAX, |s| s.1);
                while next < presses.len() && presses[next].pin_high.as_micros() < at {
                    next += 1;
                }
                let e = &mut self.notes[id as usize];
                let outcome = match presses.get(next) {
                    Some(p) if p.pin_high.as_micros() < before => {
                        next += 1;
                        match p.sounded {
                            Some(t) => {
                                let err = t.as_nanos() as i64 / 1000 - e.score_at;
                                let ms = err as f64 / 1000.0;
                                if err > ON_TIME_US {
                                    Outcome::Late { by_ms: ms }
                                } else if err < -ON_TIME_US {
                                    Outcome::Early { by_ms: -ms }
                                } else {
                                    Outcome::OnTime { error_ms: ms }
                                }
                            }
                            None => Outcome::Unmatched,
                        }
                    }
                    _ => Outcome::Unmatched,
                };
                e.state = State::Done(outcome);
            }
        }
        self.notes
            .into_iter()
            .enumerate()
            .map(|(i, e)| NoteRecord {
                id: i as u32,
                channel: e.channel,
                note: e.note,
                score_at_us: e.score_at,
                landing: e.landing,
                outcome: match e.state {
                    State::Done(o) => o,
                    State::Unsent | State::Waiting => Outcome::Dropped(DropReason::Stopped),
                    State::Struck { .. } => Outcome::Unmatched,
                },
            })
            .collect()
    }
}
