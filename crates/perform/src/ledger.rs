//! The account of every note: what the interpreter decided, and when its strike sounded.
//!
//! [`Ledger`] takes, in order, the Note-Ons delivered to a robot (with their score note),
//! the interpreter's [`NoteEvent`]s, and the virtual robot's presses as they resolve. Each
//! note gets exactly one [`Outcome`]. Nothing is guessed from key phases: the interpreter says
//! whether a note struck, joined or was dropped and why, and the robot says when the strike
//! sounded.
//!
//! Memory: 32 bytes a note, plus the strikes of each key not yet matched to a press (a
//! handful); presses are matched as they come and not kept.

use std::collections::VecDeque;

use orch_core::{DropReason, Landing, NoteEvent};
use orch_sim::Press;

use crate::plan::NoteId;

/// How far from its score time a strike may sound and still be on time: 1 ms.
pub const ON_TIME_US: i64 = 1_000;

/// What became of one note. Times are in µs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Its own strike sounded within 1 ms of its score time.
    OnTime {
        /// Sound − score, µs.
        error_us: i32,
    },
    /// Its own strike sounded later than that.
    Late {
        /// Sound − score, µs.
        by_us: i32,
    },
    /// Its own strike sounded earlier than 1 ms before its score time.
    Early {
        /// Score − sound, µs.
        by_us: i32,
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
    /// A jump passed over it: not played, the performance having jumped (a jump forward past
    /// it, or the performer had read it ahead and not sent it when it jumped).
    Skipped,
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
            Outcome::Skipped => "skipped",
        }
    }

    /// |sound − score| of a struck note, ms.
    pub fn error_ms(&self) -> Option<f64> {
        match *self {
            Outcome::OnTime { error_us } => Some(error_us.unsigned_abs() as f64 / 1000.0),
            Outcome::Late { by_us } | Outcome::Early { by_us } => Some(by_us as f64 / 1000.0),
            _ => None,
        }
    }
}

/// One score note and what became of it: 32 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoteRecord {
    /// When the score wants it to sound, wall µs.
    pub score_at_us: i64,
    /// What became of it.
    pub outcome: Outcome,
    /// Its channel (0..=15).
    pub channel: u8,
    /// The note.
    pub note: u8,
    /// Where it landed, if it has a key.
    pub landing: Option<Landing>,
    /// Its velocity in the score (1..=127).
    pub velocity: u8,
    /// How loud its own strike sounded, on the MIDI velocity scale (the virtual robot's
    /// loudness; see `orch_sim::Press::velocity`), if it sounded.
    pub sounded_velocity: Option<u8>,
    /// When its Note-On was sent to the robot, wall µs, plus one; 0 if it was not (see
    /// [`sent_us`](Self::sent_us): 8 bytes, not an `Option`'s 16).
    sent: u64,
}

impl NoteRecord {
    /// When its Note-On was sent to the robot, wall µs, if it was.
    pub fn sent_us(&self) -> Option<u64> {
        self.sent.checked_sub(1)
    }
}

/// The outcome of a note not delivered yet, or waiting to strike: if the account closes so, it
/// was stopped.
const PENDING: Outcome = Outcome::Dropped(DropReason::Stopped);
/// The outcome of a note that struck, until a press sounds for it.
const STRUCK: Outcome = Outcome::Unmatched;

/// The account. See the [module notes](self).
#[derive(Debug, Default)]
pub struct Ledger {
    notes: Vec<NoteRecord>,
    /// Note-Ons delivered whose first event has not come yet.
    in_flight: VecDeque<NoteId>,
    /// Per key: the note whose strike it is, and the note waiting to strike.
    owner: Vec<Option<NoteId>>,
    waiting: Vec<Option<NoteId>>,
    /// Per key: whether the note waiting waits for its lead (an open hi-hat's lift), not for
    /// a re-strike's rest.
    leading: Vec<bool>,
    /// Per key: strikes (note, instant) not yet matched to a press, oldest first.
    strikes: Vec<VecDeque<(NoteId, u64)>>,
    restrikes_waited: u64,
}

impl Ledger {
    /// An account for a robot with `keys` keys.
    pub fn new(keys: usize) -> Self {
        Self {
            owner: vec![None; keys],
            waiting: vec![None; keys],
            leading: vec![false; keys],
            strikes: vec![VecDeque::new(); keys],
            ..Self::default()
        }
    }

    fn entry(&mut self, id: NoteId) -> &mut NoteRecord {
        let i = id as usize;
        if self.notes.len() <= i {
            self.notes.resize(
                i + 1,
                NoteRecord {
                    score_at_us: 0,
                    outcome: PENDING,
                    channel: 0,
                    note: 0,
                    landing: None,
                    velocity: 0,
                    sounded_velocity: None,
                    sent: 0,
                },
            );
        }
        &mut self.notes[i]
    }

    /// Score note `id` (channel, note, velocity) wants to sound at `score_at_us`.
    pub fn score(&mut self, id: NoteId, channel: u8, note: u8, velocity: u8, score_at_us: i64) {
        let e = self.entry(id);
        e.channel = channel;
        e.note = note;
        e.velocity = velocity;
        e.score_at_us = score_at_us;
    }

    /// A tempo change after note `id` was sent (early, by its press lead) moved the time it
    /// should sound to `score_at_us`. The press already sent is not taken back; the note is
    /// judged against its new time, so a note the change made late is counted late.
    pub fn rescore(&mut self, id: NoteId, score_at_us: i64) {
        self.entry(id).score_at_us = score_at_us;
    }

    /// Its Note-On was delivered to the robot at `t_us` (its first event comes when the robot
    /// decodes it).
    pub fn delivered(&mut self, id: NoteId, t_us: u64) {
        self.entry(id).sent = t_us.saturating_add(1);
        self.in_flight.push_back(id);
    }

    /// The planner dropped it.
    pub fn dropped(&mut self, id: NoteId, reason: DropReason) {
        self.entry(id).outcome = Outcome::Dropped(reason);
    }

    /// A jump passed over it (see [`Outcome::Skipped`]).
    pub fn skipped(&mut self, id: NoteId) {
        self.entry(id).outcome = Outcome::Skipped;
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
            NoteEvent::Waiting { at, .. }
            | NoteEvent::Leading { at, .. }
            | NoteEvent::Preparing { at, .. } => {
                let Some(id) = self.in_flight.pop_front() else {
                    return;
                };
                self.entry(id).landing = Some(at);
                let k = at.key as usize;
                if let (Some(w), Some(l)) = (self.waiting.get_mut(k), self.leading.get_mut(k)) {
                    *w = Some(id);
                    // Waiting for a lead or a wind note's fingers: not a re-strike's rest.
                    *l = !matches!(event, NoteEvent::Waiting { .. });
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
                let score_at = self.entry(id).score_at_us;
                // A unison: the strike it joins is for the same score instant. (With no score,
                // as for live input, the interpreter's own judgement: it joined the strike.)
                let unison = match owner.map(|o| self.notes[o as usize].score_at_us) {
                    Some(s) => s == score_at,
                    None => with_strike,
                };
                let e = self.entry(id);
                e.landing = Some(at);
                e.outcome = if unison {
                    Outcome::Unison
                } else {
                    Outcome::Joined
                };
            }
            NoteEvent::Dropped { at, reason, .. } => {
                let Some(id) = self.in_flight.pop_front() else {
                    return;
                };
                let e = self.entry(id);
                e.landing = at;
                e.outcome = Outcome::Dropped(reason);
            }
            NoteEvent::WaitOver { key } => {
                if let Some(id) = self.waiting.get_mut(key as usize).and_then(Option::take) {
                    if !self.leading[key as usize] {
                        self.restrikes_waited += 1;
                    }
                    self.strike(id, key, t_us);
                }
            }
            NoteEvent::WaitEnded { key, reason } => {
                if let Some(id) = self.waiting.get_mut(key as usize).and_then(Option::take) {
                    self.entry(id).outcome = Outcome::Dropped(reason);
                }
            }
        }
    }

    fn strike(&mut self, id: NoteId, key: u8, t_us: u64) {
        self.entry(id).outcome = STRUCK;
        if let Some(o) = self.owner.get_mut(key as usize) {
            *o = Some(id);
        }
        if let Some(s) = self.strikes.get_mut(key as usize) {
            s.push_back((id, t_us));
        }
    }

    /// A press of the virtual robot resolved (its pin went low). Presses of one key come in
    /// order. A strike is matched to the first press of its key that began at or after it and
    /// before the key's next strike; a strike passed over stays unmatched.
    pub fn press(&mut self, p: &Press) {
        let Some(queue) = self.strikes.get_mut(p.key as usize) else {
            return;
        };
        let h = p.pin_high.as_micros();
        // Strikes whose next strike came before this press found no press of their own.
        while queue.len() >= 2 && queue[1].1 <= h {
            queue.pop_front();
        }
        let Some(&(id, at)) = queue.front() else {
            return;
        };
        if at > h {
            return; // a press before any waiting strike: not a note's
        }
        queue.pop_front();
        let e = &mut self.notes[id as usize];
        e.sounded_velocity = p.velocity();
        e.outcome = match p.sounded {
            Some(t) => {
                let err = (t.as_nanos() / 1000) as i64 - e.score_at_us;
                let err = err.clamp(i32::MIN as i64, i32::MAX as i64) as i32;
                if err as i64 > ON_TIME_US {
                    Outcome::Late { by_us: err }
                } else if (err as i64) < -ON_TIME_US {
                    Outcome::Early { by_us: -err }
                } else {
                    Outcome::OnTime { error_us: err }
                }
            }
            // A wind note whose valve opened on moving fingers: no note heard.
            None if p.cracked => Outcome::Dropped(DropReason::Cracked),
            // Its strike was below the key's softest duty: the robot heard nothing.
            None if p.too_soft => Outcome::Dropped(DropReason::TooSoft),
            None => Outcome::Unmatched,
        };
    }

    /// Closes the account with the presses not handed in yet. `total` is the number of notes
    /// in the score: notes never delivered, or delivered but not decoded yet, were stopped.
    pub fn close(mut self, presses: &[Press], total: usize) -> Vec<NoteRecord> {
        if total > 0 {
            self.entry(total as u32 - 1);
        }
        let mut rest: Vec<&Press> = presses.iter().collect();
        rest.sort_by_key(|p| (p.key, p.pin_high));
        for p in rest {
            self.press(p);
        }
        self.notes
    }
}
