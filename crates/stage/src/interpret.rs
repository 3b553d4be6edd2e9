//! Raw MIDI bytes through the interpreter and the safety guard, off line (`orch interpret`):
//! every board write as it would go on the bus, and the boards' state at the end.
//!
//! Raw bytes carry no time, so byte `i` is taken to arrive at `i × 320 µs`: back to back at
//! DIN wire speed from t = 0. Timer-driven writes (hold limit, delayed re-strike, watchdog)
//! come at their own time with no byte ([`BoardWrite::byte`] `None`). Each write is shown
//! as text or JSON by [`crate::writes`].

use std::convert::Infallible;
use std::fmt::Write as _;

use orch_core::{BoardId, Counters, Duty, FingerBoards, Instant, Stats};
use orch_robot::{BoardKind, HostInterpreter, Robot, RobotError};
use serde_json::Value;

use crate::writes::{duties, duty_text, BoardState};
use crate::BoardWrite;

/// One DIN MIDI byte on the wire: 10 bits at 31250 baud.
pub const DIN_BYTE_MICROS: u64 = 320;

/// Collects the interpreter's writes as [`BoardWrite`]s.
struct Writes {
    list: Vec<BoardWrite>,
    t_us: u64,
    byte: Option<u64>,
    /// What each board is (by index): PWM boards are written duties.
    kinds: Vec<BoardKind>,
}

impl FingerBoards for Writes {
    type Error = Infallible;

    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Infallible> {
        self.list.push(BoardWrite {
            t_us: self.t_us,
            byte: self.byte,
            address: board.address,
            outputs,
            duty: None,
        });
        Ok(())
    }

    fn write_duties(&mut self, board: BoardId, duty: &[Duty; 16]) -> Result<(), Infallible> {
        if self.kinds.get(board.index as usize) != Some(&BoardKind::Pwm) {
            return self.write_board(board, orch_core::on_off(duty));
        }
        self.list.push(BoardWrite {
            t_us: self.t_us,
            byte: self.byte,
            address: board.address,
            outputs: orch_core::on_off(duty),
            duty: Some(duty.map(|d| d.get())),
        });
        Ok(())
    }
}

/// A robot's interpreter fed bytes at wire speed. See the [module notes](self).
pub struct Interpretation {
    interp: HostInterpreter,
    robot: Robot,
    writes: Writes,
    /// The next byte's index.
    index: u64,
}

/// Where an interpretation ended: the decoder's counters, whether the end of the input cut a
/// message off, the interpreter's counters, every board's state.
#[derive(Clone, Debug)]
pub struct End {
    /// The decoder's counters.
    pub counters: Counters,
    /// Whether the end of the input cut a message off.
    pub truncated: bool,
    /// The interpreter's and the guard's counters.
    pub stats: Stats,
    /// Every board's state, in the robot's order.
    pub boards: Vec<BoardState>,
}

impl Interpretation {
    /// The interpreter of `robot`, before its first byte.
    pub fn new(robot: Robot) -> Result<Self, RobotError> {
        Ok(Self {
            interp: robot.interpreter()?,
            writes: Writes {
                list: Vec::new(),
                t_us: 0,
                byte: None,
                kinds: robot.kinds.clone(),
            },
            robot,
            index: 0,
        })
    }

    /// Feeds the next byte: the writes of the timers due before (or at) its arrival, each at
    /// its own time, then the byte's own.
    pub fn push(&mut self, byte: u8) -> &[BoardWrite] {
        self.writes.list.clear();
        let now = Instant::from_micros(self.index * DIN_BYTE_MICROS);
        while let Some(due) = self.interp.next_deadline().filter(|&d| d <= now) {
            self.interp.tick(due);
            self.flush(due, None);
            if self.interp.next_deadline() == Some(due) {
                break;
            }
        }
        self.interp.feed(byte, now);
        self.flush(now, Some(self.index));
        self.index += 1;
        &self.writes.list
    }

    /// Hands the interpreter's pending writes to the list, at `t` because of `byte`.
    fn flush(&mut self, t: Instant, byte: Option<u64>) {
        self.writes.t_us = t.as_micros();
        self.writes.byte = byte;
        // A robot with PWM boards is written duties (strike, then hold); on/off boards their
        // bits.
        let flushed = if self.robot.has_dynamics() {
            self.interp
                .flush_duties(&mut self.writes)
                .map_err(|e| e.error)
        } else {
            self.interp.flush(&mut self.writes).map_err(|e| e.error)
        };
        // The list takes every write.
        let Ok(_) = flushed;
    }

    /// The end of the input.
    pub fn finish(mut self) -> End {
        let truncated = self.interp.input_ended();
        let layout = &self.interp.config().layout;
        let all = self.interp.duties();
        let boards = layout.boards[..self.robot.boards]
            .iter()
            .enumerate()
            .map(|(i, b)| BoardState {
                address: b.address,
                outputs: self.interp.frame().outputs(i),
                duty: (self.robot.kinds.get(i) == Some(&BoardKind::Pwm))
                    .then(|| all[i].map(|d| d.get())),
            })
            .collect();
        End {
            counters: self.interp.counters(),
            truncated,
            stats: *self.interp.stats(),
            boards,
        }
    }
}

impl End {
    /// The end as the last JSON line ([`crate::writes::final_json`]).
    pub fn json(&self) -> Value {
        crate::writes::final_json(&self.boards)
    }

    /// The end as the last lines of text (`#` comments): the decoder's counters, the notes
    /// and what became of them, every board's state; each line ends with a newline.
    pub fn text(&self) -> String {
        let s = &self.stats;
        let mut out = crate::messages::counters_text(&self.counters, self.truncated);
        let _ = write!(
            out,
            "\n# {} notes: {} sounded ({} of them folded, {} joined a key already down), {} dropped (channel {}{}, range {}, power {}, too fast {}, cancelled {}, stopped {}); {} re-strikes waited for their key's rest; cut: {} by the hold limit, {} by the duty limit, {} by the watchdog; at most {} keys down\n",
            s.note_ons,
            s.played + s.folded,
            s.folded,
            s.joined,
            s.dropped(),
            s.dropped_channel,
            group_drops(s),
            s.dropped_range,
            s.dropped_power,
            s.dropped_too_fast,
            s.dropped_cancelled,
            s.dropped_stopped,
            s.restrikes_delayed,
            s.cut_by_hold_limit,
            s.cut_by_duty_limit,
            s.cut_by_watchdog,
            s.peak_keys_down
        );
        let finals: Vec<String> = self
            .boards
            .iter()
            .map(|b| match &b.duty {
                Some(d) => format!("{:#04x}=[{}]", b.address, duty_text(&duties(d))),
                None => format!("{:#04x}={:#06x}", b.address, b.outputs),
            })
            .collect();
        let _ = writeln!(out, "# final: {}", finals.join(" "));
        out
    }
}

/// The drop counts of strike and fingered groups, where there are any: `, percussion N,
/// unmapped N, monophonic N` (the parts of `dropped` a keyboard alone never has).
fn group_drops(s: &orch_core::Stats) -> String {
    [
        ("percussion", s.dropped_percussion),
        ("unmapped", s.dropped_unmapped),
        ("monophonic", s.dropped_monophonic),
    ]
    .iter()
    .filter(|(_, n)| *n > 0)
    .map(|(name, n)| format!(", {name} {n}"))
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writes;

    #[test]
    fn bytes_arrive_at_wire_speed_and_every_write_says_its_byte() {
        let mut i = Interpretation::new(Robot::thesis()).unwrap();
        let mut shown = Vec::new();
        for b in [0x90, 60, 100, 0x80, 60, 0] {
            shown.extend(i.push(b).iter().map(writes::text));
        }
        assert_eq!(
            shown,
            [
                "      0.640 ms  byte 2      0x22 <- 0x0100  |........#.......|",
                "      1.600 ms  byte 5      0x22 <- 0x0000  |................|",
            ]
        );
        let end = i.finish();
        assert_eq!((end.counters.bytes, end.stats.note_ons), (6, 1));
        assert!(!end.truncated);
        assert_eq!(end.boards.len(), 4);
        assert!(end
            .text()
            .ends_with("# final: 0x21=0x0000 0x22=0x0000 0x23=0x0000 0x24=0x0000\n"));
        assert_eq!(
            end.json()["boards"][1],
            serde_json::json!({"address": 0x22, "outputs": 0})
        );
    }

    #[test]
    fn a_timer_s_write_comes_at_its_own_time_before_the_next_byte() {
        // On, off, and on again 36 ms later (Active Sensing fills the time): the guard makes
        // the key rest its 60 ms from its release first, then strikes it on a timer.
        let mut i = Interpretation::new(Robot::thesis()).unwrap();
        let mut bytes = vec![0x90, 60, 127, 0x80, 60, 0];
        bytes.extend([0xFE; 110]);
        bytes.extend([0x90, 60, 127]);
        bytes.extend([0xFE; 200]);
        let mut all = Vec::new();
        for b in bytes {
            all.extend_from_slice(i.push(b));
        }
        let strike = all
            .iter()
            .find(|w| w.byte.is_none() && w.outputs == 1 << 8)
            .expect("a timer's strike");
        assert_eq!(strike.t_us, 1600 + 60_000);
        assert_eq!(
            writes::text(strike),
            "     61.600 ms  timer       0x22 <- 0x0100  |........#.......|"
        );
    }
}
