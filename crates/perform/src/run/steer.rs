//! Following the control: a jump, a tempo change, a stop, a pause; and a live view's waits.

use super::{Run, Step};
use crate::control::{Control, Jump};
use crate::performer::{robot_err, Live, PerformError};
use crate::plan::{Jumped, ScoreEvent};
use crate::time::{ScoreTime, WallTime};

impl<S: Iterator<Item = ScoreEvent> + Clone> Run<'_, S> {
    /// Takes a jump asked of the control: every key let go, the score read again from its
    /// start up to the target, the notes passed over accounted as skipped.
    pub(super) fn follow_jump(&mut self) -> Result<(), PerformError> {
        let Some(c) = self.control.filter(|_| self.origin.is_some()) else {
            return Ok(());
        };
        let now = self.now().max(self.line.last_at);
        // A start over asked before the performance got past where its pass began changes
        // nothing.
        let (map, from) = (*self.planner.time_map(), self.passes.from);
        let here = |&(t, asked): &Jump| asked.is_some_and(|a| t == from && map.score_at(a) <= t);
        let Some((target, _)) = c.jump.take(&mut self.seen_jump).filter(|j| !here(j)) else {
            return Ok(());
        };
        let Some(origin) = self.origin.clone() else {
            return Ok(());
        };
        self.let_go_all(now)?;
        let read = self.planner.notes_read();
        let jumped = self.planner.jump(origin, now.signed(), target.as_micros());
        self.skip_passed(read, &jumped);
        self.passes.from = target;
        c.publish(*self.planner.time_map());
        Ok(())
    }

    /// Accounts for the notes a jump passed over (`read`: the score notes read before it).
    fn skip_passed(&mut self, read: u32, jumped: &Jumped) {
        let first = self.planner.notes_read();
        let p = &mut self.passes;
        let back = p.committed.is_some_and(|m| m >= first);
        let unsent = jumped.unsent.iter().filter(|u| back || u.note < first);
        for u in unsent.chain(&jumped.passed) {
            let id = u.note + p.offset;
            self.ledger
                .score(id, u.channel, u.note_number, u.velocity, u.score_at_us);
            self.ledger.skipped(id);
        }
        if back {
            p.offset += read - first;
        }
        p.committed = None;
        p.sent_ahead.clear();
        p.jumps += 1;
    }

    /// Takes a tempo change asked of the control, from now on: the notes sent ahead move
    /// with their score time.
    pub(super) fn follow_tempo(&mut self) {
        let Some(c) = self.control else {
            return;
        };
        let Some(t) = c.tempo.take(&mut self.seen_tempo) else {
            return;
        };
        let now = self.now().signed();
        let old = *self.planner.time_map();
        self.planner.set_tempo(now, t);
        let new = *self.planner.time_map();
        c.publish(new);
        let ahead = &mut self.passes.sent_ahead;
        ahead.retain(|&(_, at)| at > now);
        for (id, at) in ahead {
            *at = new.wall(old.score(*at));
            self.ledger.rescore(*id, *at);
        }
    }

    /// With a live view: waits for `due`, waking at least every 40 ms (or the control's
    /// poll) to show where the song is, and at once when the control rings (a request); the
    /// last stretch before a send is one precise wait, with nothing else in it.
    pub(super) fn wait_live(&mut self, due: WallTime) -> Result<Step, PerformError> {
        loop {
            let seen = self.rung();
            if self.control.is_some_and(Control::stopping) {
                self.stopped_at = Some(self.now().max(self.line.last_at));
                return Ok(Step::Stop);
            }
            if let Some(c) = self.control.filter(|c| c.paused()) {
                self.pause(c)?;
                return Ok(Step::Again);
            }
            let (tempo, jump) = (self.seen_tempo, self.seen_jump);
            if self
                .control
                .is_some_and(|c| c.tempo.pending(tempo).is_some() || c.jump.pending(jump).is_some())
            {
                return Ok(Step::Again);
            }
            let now = self.now();
            if now + self.every >= due {
                if self.wait(due, seen) {
                    continue;
                }
                return Ok(Step::Go);
            }
            if self.wait(now + self.every, seen) {
                continue;
            }
            // In a jump's lead-in, the target.
            let song = self.planner.time_map().score_at(self.now());
            self.show(song.max(self.passes.from), false);
        }
    }

    /// Paused: every key up, score time held, until resumed (or stopped). The robot's own
    /// timers run on (a strike held for its shortest sounding press lets go now).
    fn pause(&mut self, c: &Control) -> Result<(), PerformError> {
        let at = self.now().max(self.line.last_at);
        self.let_go_all(at)?;
        let song = self.planner.time_map().score_at(at);
        loop {
            let seen = c.bell().rung();
            if !c.paused() || c.stopping() {
                break;
            }
            let now = self.now();
            self.wait(now + self.every, seen);
            let now = self.now();
            self.robot.advance(now.as_micros()).map_err(robot_err)?;
            self.account_robot();
            let shown = c.jump.pending(self.seen_jump).map_or(song, |j| j.0);
            self.show(shown, true);
        }
        let now = self.now().max(at);
        self.planner.resume(at.signed(), now.signed());
        c.publish(*self.planner.time_map());
        Ok(())
    }

    /// Tells the live view where the performance stands.
    fn show(&mut self, song: ScoreTime, paused: bool) {
        let live = Live {
            song_us: song.as_micros(),
            keys_down: self.robot.keys_down(),
            notes_sent: self.notes_sent,
            tempo: self.planner.time_map().tempo().get(),
            paused,
            stats: *self.robot.interpreter().stats(),
        };
        if let Some(l) = self.live.as_deref_mut() {
            l(&live);
        }
    }
}
