//! Sending: each planned message to the robot side, and the account of it.

use super::Run;
use crate::link::{DinWire, Link, MidiOut, RunningStatus};
use crate::performer::{robot_err, PerformError};
use crate::plan::{NoteId, Planned, ScoreEvent};
use crate::time::WallTime;
use orch_seq::WireBytes;

/// A [`MidiOut`] of any error type, as the performer holds it (behind a `dyn`, so no call
/// site names an output's type).
pub(crate) trait SendMidi {
    fn send(&mut self, t: WallTime, bytes: &[u8]) -> Result<(), PerformError>;
    fn next_deadline(&self) -> Option<WallTime>;
    fn poll(&mut self, t: WallTime) -> Result<(), PerformError>;
    fn finish(&mut self, t: WallTime) -> Result<(), PerformError>;
}

fn midi_err(e: impl std::error::Error + Send + Sync + 'static) -> PerformError {
    PerformError::Midi(Box::new(e))
}

impl<M: MidiOut> SendMidi for M {
    fn send(&mut self, t: WallTime, bytes: &[u8]) -> Result<(), PerformError> {
        MidiOut::send(self, t.as_micros(), bytes).map_err(midi_err)
    }
    fn next_deadline(&self) -> Option<WallTime> {
        MidiOut::next_deadline(self).map(WallTime::from_micros)
    }
    fn poll(&mut self, t: WallTime) -> Result<(), PerformError> {
        MidiOut::poll(self, t.as_micros()).map_err(midi_err)
    }
    fn finish(&mut self, t: WallTime) -> Result<(), PerformError> {
        MidiOut::finish(self, t.as_micros()).map_err(midi_err)
    }
}

/// Where the bytes go.
pub(super) enum Out<'a> {
    /// The virtual robot is the robot.
    Virtual,
    /// A MIDI output, the virtual robot its copy at the far end of the line.
    Midi {
        out: &'a mut dyn SendMidi,
        wire: DinWire,
        status: RunningStatus,
    },
}

impl<'a> Out<'a> {
    pub(super) fn new(midi: Option<&'a mut dyn SendMidi>) -> Self {
        match midi {
            Some(out) => Out::Midi {
                out,
                wire: DinWire::default(),
                status: RunningStatus::default(),
            },
            None => Out::Virtual,
        }
    }

    /// When the output must next be polled, if ever.
    pub(super) fn next_deadline(&self) -> Option<WallTime> {
        match self {
            Out::Midi { out, .. } => out.next_deadline(),
            Out::Virtual => None,
        }
    }

    pub(super) fn poll(&mut self, t: WallTime) -> Result<(), PerformError> {
        match self {
            Out::Midi { out, .. } => out.poll(t),
            Out::Virtual => Ok(()),
        }
    }

    pub(super) fn finish(&mut self, t: WallTime) -> Result<(), PerformError> {
        match self {
            Out::Midi { out, .. } => out.finish(t),
            Out::Virtual => Ok(()),
        }
    }

    /// When the line is free again (the start of the clock for no line).
    pub(super) fn free_at(&self) -> WallTime {
        match self {
            Out::Midi { wire, .. } => WallTime::from_micros(wire.free_at()),
            Out::Virtual => WallTime::ZERO,
        }
    }
}

impl<S: Iterator<Item = ScoreEvent> + Clone> Run<'_, S> {
    /// Sends (or drops) the next planned message, due at `next`: whether the song goes on.
    pub(super) fn send_next(&mut self, next: WallTime) -> Result<bool, PerformError> {
        let Some(p) = self.planner.next_planned() else {
            return Ok(false);
        };
        self.line.burst = self.line.burst.saturating_sub(1);
        match p {
            Planned::Send {
                bytes,
                note,
                score_at_us,
                ..
            } => self.send(next, &bytes, note, score_at_us)?,
            Planned::Dropped {
                score_at_us,
                channel,
                note_number,
                velocity,
                note,
                reason,
                ..
            } => {
                self.commit(note);
                let note = note + self.passes.offset;
                self.ledger
                    .score(note, channel, note_number, velocity, score_at_us);
                self.ledger.dropped(note, reason);
            }
        }
        Ok(true)
    }

    /// Sends `bytes` (score note `note`'s, if any, to sound at `score_at_us`, planner wall
    /// µs) at `next`, or as soon after the last send as may be.
    fn send(
        &mut self,
        next: WallTime,
        bytes: &WireBytes,
        note: Option<NoteId>,
        score_at_us: i64,
    ) -> Result<(), PerformError> {
        if let Some(i) = note {
            self.commit(i);
        }
        let note = note.map(|i| i + self.passes.offset);
        if let (Some(id), Some((ch, n, v))) = (note, bytes.note_on()) {
            self.ledger.score(id, ch, n, v, score_at_us);
            self.notes_sent += 1;
            let now = self.now().signed();
            let ahead = &mut self.passes.sent_ahead;
            ahead.retain(|&(_, at)| at > now);
            ahead.push((id, score_at_us));
        }
        let t = next.max(self.line.last_at);
        let left = self.deliver(t, bytes, note)?;
        if self.lateness.is_some() {
            let late = left.saturating_since(t);
            if let Some(l) = self.lateness.as_mut() {
                l.push(late);
            }
            if let Some(id) = note.filter(|_| bytes.note_on().is_some()) {
                let i = id as usize;
                if self.note_lateness.len() <= i {
                    self.note_lateness.resize(i + 1, None);
                }
                self.note_lateness[i] = Some(u32::try_from(late).unwrap_or(u32::MAX));
            }
        }
        self.line.last_at = t;
        self.line.last_byte = Some(t);
        Ok(())
    }

    /// Score note `i` (its index in the score) was sent or dropped.
    fn commit(&mut self, i: NoteId) {
        let c = &mut self.passes.committed;
        *c = Some(c.map_or(i, |m| m.max(i)));
    }

    /// Lets every key go at `at`, on every channel: All Notes Off and All Sound Off (the
    /// pedal's notes too). Nothing is sent before it after that.
    pub(super) fn let_go_all(&mut self, at: WallTime) -> Result<(), PerformError> {
        for ch in 0..16u8 {
            for cc in [123, 120] {
                self.deliver(at, &[0xB0 | ch, cc, 0], None)?;
            }
        }
        self.line.last_at = at;
        self.line.last_byte = Some(at);
        self.line.burst = 0;
        Ok(())
    }

    /// Hands one message to the robot side at `t`. Returns when the bytes left, on the clock
    /// (before the virtual robot takes them).
    pub(super) fn deliver(
        &mut self,
        t: WallTime,
        bytes: &[u8],
        note: Option<NoteId>,
    ) -> Result<WallTime, PerformError> {
        if let Some(id) = note {
            self.ledger.delivered(id, t.as_micros());
        }
        let link = self.setup.link;
        let left = match &mut self.out {
            Out::Virtual => {
                let left = super::now_on(&self.clock, &self.virtual_clock);
                self.robot.feed(t.as_micros(), bytes).map_err(robot_err)?;
                left
            }
            Out::Midi { out, wire, status } => {
                let sent = status.compress(bytes);
                out.send(t, sent)?;
                let left = super::now_on(&self.clock, &self.virtual_clock);
                let t = t.as_micros();
                for &b in sent {
                    let at = match link {
                        Link::Din => wire.arrivals(t, 1).next().unwrap_or(t),
                        Link::Direct => t,
                    };
                    self.robot.feed(at, &[b]).map_err(robot_err)?;
                }
                left
            }
        };
        self.account_robot();
        Ok(left)
    }
}

/// A DIN line carries one byte every 320 µs, so the messages of a chord arrive one after
/// another. The planner sends each note message early by two bytes (its length under running
/// status); here the head of the queue and the final sends that would queue behind it on the
/// line go out as one burst, started so that their arrivals are centred on the head's time:
/// for a lone message, early by its own length; for a 10-note chord (21 bytes, 6.7 ms), the
/// first arrives about 3 ms early and the last about 3 ms late. Returns the burst's send time
/// (planner wall µs) and how many sends it holds.
pub(super) fn din_burst(finals: &[&Planned], mut status: RunningStatus) -> (i64, usize) {
    let byte = Link::DIN_BYTE_US as i64;
    let Some(head) = finals.first() else {
        return (0, 0);
    };
    let t0 = head.at_us();
    let target = t0 + Link::Din.note_lead_us() as i64;
    let (mut cum, mut sum, mut members, mut sends) = (0i64, 0i64, 0usize, 0i64);
    for p in finals {
        if let Planned::Send { at_us, bytes, .. } = p {
            if members > 0 && *at_us >= t0 + cum * byte {
                break;
            }
            cum += status.compress(bytes).len() as i64;
            sum += cum;
            sends += 1;
        }
        members += 1;
    }
    let mean_arrival = if sends > 0 { sum * byte / sends } else { 0 };
    (target - mean_arrival, members.max(1))
}
