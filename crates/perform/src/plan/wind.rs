//! The planner and a fingered group (a wind robot): each note sent early by the fingers'
//! settle time and the valve's (its press lead: the air's rise and the write), and by the
//! valve's closing when the note before still sounds then; a note that ends as the next begins
//! hands over: its Note-Off goes with the next Note-On, just before it, so the one voice moves
//! on.

use super::{Planner, QueueKey};
use crate::{NoteId, ScoreEvent};
use orch_seq::WireBytes;

/// What the planner keeps of the fingered group.
#[derive(Clone, Debug, Default)]
pub(super) struct WindPlan {
    /// Its Note-Offs planned and perhaps not sent yet: (queue key, score time).
    offs: Vec<(QueueKey, i64)>,
    /// The notes held at the score's present, in the order they came: the voice the group
    /// plays picks among them, as the core does.
    held: Vec<u8>,
    /// The last note the voice plays.
    last: Option<Last>,
}

/// The last note the group's voice plays.
#[derive(Clone, Copy, Debug)]
struct Last {
    /// Its score time, and when it was sent.
    w: i64,
    at: i64,
    /// When its valve opens.
    opens: i64,
    note: u8,
    /// Its Note-Off, once planned.
    off: Option<QueueKey>,
}

impl WindPlan {
    /// The held note the voice plays, as the core picks it.
    fn pick(&self, voice: orch_core::Voice) -> Option<u8> {
        match voice {
            orch_core::Voice::Highest => self.held.iter().copied().max(),
            orch_core::Voice::Lowest => self.held.iter().copied().min(),
            orch_core::Voice::Last => self.held.last().copied(),
        }
    }
}

impl<S: Iterator<Item = ScoreEvent>> Planner<S> {
    /// A Note-On the fingered group plays (on its valve, `k`).
    pub(super) fn wind_on(&mut self, ch: u8, k: usize, w: i64, bytes: WireBytes, id: NoteId) {
        let Some((_, note, velocity)) = bytes.note_on() else {
            return;
        };
        let (settle, close) = self.rules.keys.wind_times_us();
        let fingers_at = w - self.rules.press_lead(k, velocity) as i64 - settle;
        self.wind.held.retain(|&n| n != note);
        self.wind.held.push(note);
        let chord = self.wind.last.filter(|l| l.w == w);
        let at = if self.wind.pick(self.rules.keys.voice()) != Some(note) {
            // The voice plays another note held: the core drops this one (monophonic).
            fingers_at
        } else if let Some(first) = chord {
            // A chord's note that wins over the one before it: sent with it.
            self.wind.last = Some(Last {
                note,
                off: None,
                ..first
            });
            first.at
        } else {
            self.wind_voice_on(w, fingers_at, close, settle, note)
        };
        let at = self.after_controller(ch, at);
        self.send(at, bytes, Some(id), w);
        self.mark(ch, k, at);
    }

    /// The voice moves to `note` at `w`: sent at `fingers_at`, or earlier by `close` if the
    /// note before still sounds then; the notes that end by `w` hand over to it.
    fn wind_voice_on(&mut self, w: i64, fingers_at: i64, close: i64, settle: i64, note: u8) -> i64 {
        let cut = fingers_at - close;
        // Whether the note before sounds at `cut`: its valve open by then, its Note-Off later
        // (or not read yet). Then the valve must close and the air stop first.
        let sounding = self
            .wind
            .last
            .is_some_and(|l| l.opens < cut && l.off.is_none_or(|q| q.0 > cut));
        let at = if sounding { cut } else { fingers_at };
        // The notes that end by this one's start hand over to it.
        self.wind_hand_over(at, w);
        self.wind.last = Some(Last {
            w,
            at,
            opens: at + if sounding { close } else { 0 } + settle,
            note,
            off: None,
        });
        at
    }

    /// Moves the group's Note-Offs of notes that end by `w` and would go after `at` to `at`
    /// (sent before the Note-On that follows: queued earlier).
    fn wind_hand_over(&mut self, at: i64, w: i64) {
        let offs = std::mem::take(&mut self.wind.offs);
        for (q, score_end) in offs {
            if !self.queue.contains_key(&q) {
                continue; // sent already
            }
            if q.0 > at && score_end <= w {
                self.stats.releases_moved_early += 1;
                let nq = self.move_to(q, at);
                if let Some(l) = &mut self.wind.last {
                    if l.off == Some(q) {
                        l.off = Some(nq);
                    }
                }
                self.wind.offs.push((nq, score_end));
            } else {
                self.wind.offs.push((q, score_end));
            }
        }
    }

    /// After the map changed (a tempo change): the group's Note-Offs follow their sends
    /// (`renamed`: each send's new time by its sequence number; a send not in it has gone),
    /// its times follow the map.
    pub(super) fn wind_remap(
        &mut self,
        renamed: &std::collections::HashMap<u64, i64>,
        remap: impl Fn(i64) -> i64,
    ) {
        let follow = |q: QueueKey| renamed.get(&q.1).map(|&t| (t, q.1));
        self.wind.offs = std::mem::take(&mut self.wind.offs)
            .into_iter()
            .filter_map(|(q, end)| Some((follow(q)?, remap(end))))
            .collect();
        if let Some(l) = &mut self.wind.last {
            (l.w, l.at, l.opens) = (remap(l.w), remap(l.at), remap(l.opens));
            // A Note-Off already sent keeps its (past) time.
            l.off = l.off.map(|q| follow(q).unwrap_or(q));
        }
    }

    /// A Note-Off of the fingered group: at its score time (the valve closes then).
    pub(super) fn wind_off(&mut self, ch: u8, w: i64, bytes: WireBytes) {
        let at = self.after_controller(ch, w);
        let note = bytes.note_off().map(|(_, n)| n);
        let q = self.send(at, bytes, None, w);
        self.wind.offs.push((q, w));
        let Some(note) = note else { return };
        self.wind.held.retain(|&n| n != note);
        if let Some(l) = self.wind.last.as_mut().filter(|l| l.note == note) {
            l.off = l.off.or(Some(q));
        }
    }
}
