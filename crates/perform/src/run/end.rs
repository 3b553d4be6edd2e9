//! The end: the last key let sound, the line let go, every note accounted for.

use super::Run;
use crate::performer::{robot_err, PerformError};
use crate::plan::ScoreEvent;
use crate::played::Played;
use crate::time::WallTime;

impl<S: Iterator<Item = ScoreEvent> + Clone> Run<'_, S> {
    /// The song is over (or stopped): ends the sending, then accounts for every note.
    pub(super) fn finish(mut self) -> Result<Played, PerformError> {
        let end_at = self.end_sending()?;
        self.account(end_at)
    }

    /// A key struck at the song's very end (a note with no Note-Off before the end of the
    /// file) is still let sound: the end comes its shortest sounding press after the last
    /// send. Then a robot that interprets MIDI itself is told to let go of everything, on
    /// every channel. Returns when the sending ended.
    fn end_sending(&mut self) -> Result<WallTime, PerformError> {
        let settle = self.setup.settle_us();
        let end_at = match self.stopped_at {
            Some(t) => t.max(self.line.last_at),
            None => {
                let t = self.line.last_at.max(self.out.free_at()) + settle;
                self.clock().wait_until(t.as_micros());
                t
            }
        };
        if let super::Out::Midi { .. } = self.out {
            for ch in 0..16u8 {
                self.deliver(end_at, &[0xB0 | ch, 123, 0], None)?;
            }
            self.out.finish(end_at)?;
            self.line.last_at = end_at;
        }
        Ok(end_at)
    }

    /// The robot settled (or stopped), the account closed: the performance as played.
    fn account(mut self, end_at: WallTime) -> Result<Played, PerformError> {
        let wire_end = self.out.free_at();
        let drained = match self.stopped_at {
            Some(t) => self.robot.stop(t.max(wire_end).as_micros()),
            None => {
                let t = end_at.max(self.line.last_at).max(wire_end) + 1;
                self.robot.drain(t.as_micros())
            }
        }
        .map_err(robot_err)?;
        self.account_robot();
        let end = drained + self.setup.longest_release_us() + 1_000;
        let restrikes_waited = self.ledger.restrikes_waited();
        let (interp, performance) = self.robot.finish(end);
        let passes = self.passes;
        let total = self.notes + passes.offset as usize;
        Ok(Played {
            records: self.ledger.close(&performance.presses, total),
            performance,
            stats: *interp.stats(),
            plan: self.planner.stats(),
            note_lateness_us: self.lateness.is_some().then(|| {
                let mut l = self.note_lateness;
                l.resize(total, None);
                l
            }),
            lateness_us: self.lateness,
            start_us: self.start.as_micros(),
            end_us: end,
            restrikes_waited,
            stopped: self.stopped_at.is_some(),
            jumps: passes.jumps,
            replayed: u64::from(passes.offset),
            dynamic_keys: self.setup.dynamic_keys(),
            extra_keys: self.setup.extra_keys(),
            finger_keys: self.setup.finger_keys(),
            groups: self.setup.groups.clone(),
        })
    }
}
