//! The interpreter playing its fingered group: see [`wind`](crate::wind) for the rules.

use super::Interpreter;
use crate::config::ConfigSource;
use crate::fingers::{DOWN, PENDING};
use crate::held::HeldNotes;
use crate::outcome::{DropReason, Landing, NoteEvent, NoteSink};
use crate::values::{Channel, Note, Velocity};
use crate::wind::Phase;

impl<const B: usize, const K: usize, H: HeldNotes, C: ConfigSource<B>> Interpreter<B, K, H, C> {
    /// A Note-On the fingered group takes (it landed on its valve, `at`).
    pub(super) fn wind_note_on<S: NoteSink>(
        &mut self,
        channel: Channel,
        note: Note,
        velocity: Velocity,
        at: Landing,
        now: u32,
        sink: &mut S,
    ) {
        let wind = self.config.wind;
        let Some(of) = wind.find(note) else {
            return; // `land` found it: unreachable
        };
        if of.octaves != 0 {
            self.count(|s| s.folded_octaves += of.octaves.unsigned_abs() as u32);
        }
        let n = note.get();
        let again = self.wind_state.target.is_some_and(|t| t.0 == n) && !self.wind_state.released;
        self.wind_state.hold(n);
        if self.wind_state.pick(wind.voice) != Some(n) {
            self.count(|s| s.dropped_monophonic += 1);
            sink.note(NoteEvent::Dropped {
                channel,
                note,
                at: Some(at),
                reason: DropReason::Monophonic,
            });
            return;
        }
        if again && self.wind_state.phase != Phase::Open {
            // The same note again while it prepares (another channel's doubling): it joins.
            self.count_sounded(of.octaves != 0);
            self.count(|s| s.joined += 1);
            sink.note(NoteEvent::Joined {
                channel,
                note,
                at,
                with_strike: true,
            });
            return;
        }
        self.wind_supersede(sink);
        self.wind_state.target = Some((n, of.key, velocity.get(), of.octaves));
        self.wind_state.released = false;
        self.wind_close(now);
        sink.note(NoteEvent::Preparing { channel, note, at });
    }

    /// The note preparing (not sounded yet) loses its place to a new one: dropped, as
    /// `Monophonic` if it is still held (a chord), else `TooFast`.
    fn wind_supersede<S: NoteSink>(&mut self, sink: &mut S) {
        let st = self.wind_state;
        let Some((old, ..)) = st.target else { return };
        if st.phase == Phase::Open || st.phase == Phase::Idle {
            return;
        }
        let reason = if st.holds(old) && !st.released {
            self.count(|s| s.dropped_monophonic += 1);
            DropReason::Monophonic
        } else {
            self.count(|s| s.dropped_too_fast += 1);
            DropReason::TooFast
        };
        sink.note(NoteEvent::WaitEnded {
            key: self.config.wind.valve(),
            reason,
        });
    }

    /// A Note-Off for the fingered group.
    pub(super) fn wind_note_off(&mut self, note: Note, now: u32) {
        let n = note.get();
        self.wind_state.let_go(n);
        if self.wind_state.cut_note == n && self.wind_state.phase == Phase::Idle {
            // The note the guard cut ends: the air stops `close` from now, as if its valve
            // had been open until its Note-Off, so the next note waits for it as planned.
            self.wind_state.cut_note = crate::wind::NO_NOTE;
            let until = now.wrapping_add(self.config.wind.close.as_micros());
            self.wind_state.phase = Phase::Closing { until };
            self.due = self.due.min(until);
            return;
        }
        if self.wind_state.target.is_none_or(|t| t.0 != n) || self.wind_state.released {
            return;
        }
        self.wind_state.released = true;
        if self.wind_state.phase == Phase::Open {
            // Held at least `min_press` from the valve's opening, as a key's late strike is.
            let age = self.fingers.age(self.config.wind.valve(), now);
            let min = self.config.guard.min_press.as_micros();
            if age >= min {
                self.wind_state.target = None;
                self.wind_close(now);
            } else {
                self.due = self.due.min(now.wrapping_add(min - age));
            }
        }
        // Still preparing: it sounds once its fingers settle, for `min_press`.
    }

    /// All Notes Off (or All Sound Off) on one of its channels: every note held lets go; the
    /// note playing ends as its own Note-Off would end it.
    pub(super) fn wind_all_notes_off(&mut self, now: u32) {
        self.wind_state.clear_notes();
        if let Some((n, ..)) = self.wind_state.target {
            self.wind_note_off(Note::from_bits(n), now);
        }
    }

    /// Closes the valve now and moves to `Closing`: the fingers move (or are released, with
    /// no target) once the valve's closing is written and the close time has passed.
    fn wind_close(&mut self, now: u32) {
        let wind = self.config.wind;
        let valve = wind.valve();
        // The air takes `close` to stop once the valve closes; a valve already closed waits
        // only for its closing to be written.
        let mut close = 0;
        if matches!(self.fingers.phase(valve), DOWN | PENDING) {
            self.release_now(valve, now);
            close = wind.close.as_micros();
        }
        let mut until = now.wrapping_add(close);
        if let Phase::Closing { until: before } = self.wind_state.phase {
            // Already closing: the air has not stopped any sooner.
            if before.wrapping_sub(until) as i32 > 0 {
                until = before;
            }
        }
        self.wind_state.phase = Phase::Closing { until };
        self.due = self.due.min(until);
    }

    /// The group's timers at `now`: returns how long until its next one, µs.
    pub(super) fn wind_timers<S: NoteSink>(&mut self, now: u32, sink: &mut S) -> Option<u32> {
        let left = |until: u32| until.wrapping_sub(now) as i32;
        match self.wind_state.phase {
            Phase::Idle => None,
            Phase::Closing { until } if left(until) > 0 => Some(left(until) as u32),
            Phase::Closing { .. } => {
                if !self.wind_valve_written() {
                    return Some(0); // the valve's closing is not on the boards yet
                }
                match self.wind_state.target {
                    Some((_, index, ..)) => {
                        self.wind_set_fingers(self.config.wind.fingering(index).fingers, now);
                        let until = now.wrapping_add(self.config.wind.settle.as_micros());
                        self.wind_state.phase = Phase::Settling { until };
                        Some(left(until).max(0) as u32)
                    }
                    None => {
                        self.wind_set_fingers(0, now);
                        self.wind_state.phase = Phase::Idle;
                        None
                    }
                }
            }
            Phase::Settling { until } if left(until) > 0 => Some(left(until) as u32),
            Phase::Settling { .. } => Some(self.wind_open(now, sink)),
            Phase::Open => self.wind_open_timer(now),
        }
    }

    /// The fingers have settled: the valve opens at the note's breath and velocity.
    fn wind_open<S: NoteSink>(&mut self, now: u32, sink: &mut S) -> u32 {
        let wind = self.config.wind;
        let Some((_, _, velocity, octaves)) = self.wind_state.target else {
            return u32::MAX;
        };
        let valve = wind.valve();
        self.fingers.set_velocity(valve, velocity);
        self.count_sounded(octaves != 0);
        self.press_now(valve, now);
        let limit = self.arm(valve, now);
        self.wind_state.phase = Phase::Open;
        sink.note(NoteEvent::WaitOver { key: valve });
        if self.wind_state.released {
            let min = self.config.guard.min_press.as_micros();
            self.due = self.due.min(now.wrapping_add(min));
            return min.min(limit);
        }
        limit
    }

    /// While the valve is open: a note released within `min_press` of its opening closes it
    /// once that has passed.
    fn wind_open_timer(&mut self, now: u32) -> Option<u32> {
        if !self.wind_state.released {
            return None;
        }
        let age = self.fingers.age(self.config.wind.valve(), now);
        let min = self.config.guard.min_press.as_micros();
        if age >= min {
            self.wind_state.target = None;
            self.wind_close(now);
            Some(self.config.wind.close.as_micros())
        } else {
            Some(min - age)
        }
    }

    /// Whether the valve is off on the boards (its closing written).
    fn wind_valve_written(&self) -> bool {
        let valve = self.config.wind.valve();
        self.config
            .layout
            .finger(valve)
            .is_none_or(|f| !self.frame.is_written(f.board, f.bit))
    }

    /// Sets the fingers to `mask` (bit `i`: finger `i` down), the valve closed.
    fn wind_set_fingers(&mut self, mask: u16, now: u32) {
        let wind = self.config.wind;
        for i in 0..wind.fingers {
            let key = wind.finger(i);
            let want = mask & (1 << i) != 0;
            let down = self.fingers.phase(key) == DOWN;
            if want && !down {
                self.fingers.set_velocity(key, Velocity::MAX.get());
                self.press_now(key, now);
                self.arm(key, now);
            } else if !want && down {
                self.release_now(key, now);
            }
        }
    }

    /// The guard cut one of the group's outputs (hold or duty limit): the whole group stops,
    /// the valve with it; a note still preparing is cancelled. The notes held stay held (their
    /// Note-Offs let them go): a chord's lower note arriving after the cut does not sound in
    /// its melody's place.
    pub(super) fn wind_cut<S: NoteSink>(&mut self, now: u32, sink: &mut S) {
        let st = self.wind_state;
        self.wind_state.cut_note = st
            .target
            .filter(|_| st.phase != Phase::Idle && !st.released)
            .map_or(crate::wind::NO_NOTE, |t| t.0);
        if st.target.is_some() && matches!(st.phase, Phase::Closing { .. } | Phase::Settling { .. })
        {
            self.count(|s| s.dropped_cancelled += 1);
            sink.note(NoteEvent::WaitEnded {
                key: self.config.wind.valve(),
                reason: DropReason::Cancelled,
            });
        }
        // The notes held stay held: a lower note of the chord arriving next still loses.
        self.wind_state.target = None;
        let wind = self.config.wind;
        for key in wind.first..=wind.first + wind.fingers {
            self.release_now(key, now);
        }
        self.wind_state.phase = Phase::Idle;
    }

    /// Everything is released (`all_off`, the watchdog, a reset): a note still preparing is
    /// stopped or cancelled; the group forgets its notes. Its outputs are released with every
    /// other key, in one frame, the valve's board first.
    pub(super) fn wind_reset<S: NoteSink>(&mut self, why: DropReason, sink: &mut S) {
        let st = self.wind_state;
        let waiting = st.target.is_some()
            && matches!(st.phase, Phase::Closing { .. } | Phase::Settling { .. });
        if waiting {
            if why == DropReason::Stopped {
                self.count(|s| s.dropped_stopped += 1);
            } else {
                self.count(|s| s.dropped_cancelled += 1);
            }
            sink.note(NoteEvent::WaitEnded {
                key: self.config.wind.valve(),
                reason: why,
            });
        }
        self.wind_state = Default::default();
    }
}
