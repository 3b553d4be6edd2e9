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
    /// The last note planned: when its valve opens, and its Note-Off once planned.
    last: Option<(i64, Option<QueueKey>)>,
}

impl<S: Iterator<Item = ScoreEvent>> Planner<S> {
    /// A Note-On the fingered group plays (on its valve, `k`).
    pub(super) fn wind_on(&mut self, ch: u8, k: usize, w: i64, bytes: WireBytes, id: NoteId) {
        let velocity = bytes.note_on().map_or(0, |(_, _, v)| v);
        let (settle, close) = self.rules.keys.wind_times_us();
        let fingers_at = w - self.rules.press_lead(k, velocity) as i64 - settle;
        let cut = fingers_at - close;
        // Whether the note before sounds at `cut`: its valve open by then, its Note-Off later
        // (or not read yet). Then the valve must close and the air stop first.
        let sounding = self
            .wind
            .last
            .is_some_and(|(opens, off)| opens < cut && off.is_none_or(|q| q.0 > cut));
        let at = if sounding { cut } else { fingers_at };
        // The notes that end by this one's start hand over to it.
        self.wind_hand_over(at, w);
        let at = self.after_controller(ch, at);
        self.send(at, bytes, Some(id), w);
        self.mark(ch, k, at);
        self.wind.last = Some((at + if sounding { close } else { 0 } + settle, None));
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
                if let Some((_, off)) = &mut self.wind.last {
                    if *off == Some(q) {
                        *off = Some(nq);
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
        if let Some((opens, off)) = &mut self.wind.last {
            *opens = remap(*opens);
            // A Note-Off already sent keeps its (past) time.
            *off = off.map(|q| follow(q).unwrap_or(q));
        }
    }

    /// A Note-Off of the fingered group: at its score time (the valve closes then).
    pub(super) fn wind_off(&mut self, ch: u8, w: i64, bytes: WireBytes) {
        let at = self.after_controller(ch, w);
        let q = self.send(at, bytes, None, w);
        self.wind.offs.push((q, w));
        if let Some((_, off @ None)) = &mut self.wind.last {
            *off = Some(q);
        }
    }
}
