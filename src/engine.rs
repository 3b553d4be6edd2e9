//! The engine: timed MIDI bytes through the interpreter onto the virtual robot.
//!
//! Bytes go in with the time they arrive (µs on the engine's clock). Everything that happens at
//! one instant is written to the boards together when time moves on, so a chord on one board
//! is one bus write; the guard's timers fire at their own deadlines in between.

use anyhow::Context;
use orch_core::{Counters, Instant, Stats};
use orch_sim::{Performance, VirtualRobot};

use crate::robot::{HostInterpreter, Robot};

pub struct Engine {
    interp: HostInterpreter,
    robot: VirtualRobot,
    /// The instant whose changes are not yet on the bus.
    batch: Option<u64>,
}

impl Engine {
    /// A robot as `robot` says, with its boards initialised at t = 0.
    pub fn new(robot: &Robot) -> anyhow::Result<Self> {
        let mut sim = VirtualRobot::new(robot.sim_config());
        sim.init().context("initialising the virtual boards")?;
        Ok(Self {
            interp: robot.interpreter()?,
            robot: sim,
            batch: None,
        })
    }

    /// When the boards are ready: the end of their initialisation on the bus.
    pub fn ready_us(&self) -> u64 {
        self.robot.bus().free_at().as_micros() + 1
    }

    pub fn interpreter(&self) -> &HostInterpreter {
        &self.interp
    }

    /// Feeds one byte arriving at `t_us` (never earlier than the previous byte).
    pub fn push(&mut self, t_us: u64, byte: u8) -> anyhow::Result<()> {
        if self.batch != Some(t_us) {
            self.advance(t_us)?;
        }
        self.interp.feed(byte, Instant::from_micros(t_us));
        self.batch = Some(t_us);
        Ok(())
    }

    /// Feeds a chunk of bytes that all arrived at `t_us`.
    pub fn push_slice(&mut self, t_us: u64, bytes: &[u8]) -> anyhow::Result<()> {
        for &b in bytes {
            self.push(t_us, b)?;
        }
        Ok(())
    }

    /// Puts the last instant's changes on the bus and fires every timer due before `t_us`.
    pub fn advance(&mut self, t_us: u64) -> anyhow::Result<()> {
        if let Some(t) = self.batch.take() {
            self.flush(t)?;
        }
        while let Some(due) = self.interp.next_deadline().filter(|d| d.as_micros() < t_us) {
            self.interp.tick(due);
            self.flush(due.as_micros())?;
            if self.interp.next_deadline() == Some(due) {
                break;
            }
        }
        Ok(())
    }

    /// Runs every timer still pending (delayed re-strikes, short presses, the watchdog for a
    /// key left down), then releases everything. Returns the time it ended.
    pub fn drain(&mut self, t_us: u64) -> anyhow::Result<u64> {
        self.advance(t_us)?;
        let mut end = t_us;
        while let Some(due) = self.interp.next_deadline() {
            self.interp.tick(due);
            end = end.max(due.as_micros());
            self.flush(end)?;
            if self.interp.next_deadline() == Some(due) {
                break;
            }
        }
        self.interp.all_off(Instant::from_micros(end));
        self.flush(end)?;
        Ok(end)
    }

    /// Stops at `t_us`: everything that happened is written, then every key is released at
    /// once (a person stopped the performance). Returns the time it ended.
    pub fn stop(&mut self, t_us: u64) -> anyhow::Result<u64> {
        self.advance(t_us)?;
        self.interp.all_off(Instant::from_micros(t_us));
        self.flush(t_us)?;
        Ok(t_us)
    }

    fn flush(&mut self, t_us: u64) -> anyhow::Result<()> {
        self.robot.set_time(Instant::from_micros(t_us));
        self.interp
            .flush(&mut self.robot)
            .map_err(|e| anyhow::anyhow!("board {:#04x}: {}", e.board.address, e.error))?;
        Ok(())
    }

    /// Whether each key is down now.
    pub fn keys_down(&self) -> Vec<bool> {
        let keys = self.interp.config().range.keys();
        (0..keys).map(|k| self.interp.is_down(k as u8)).collect()
    }

    /// Ends the performance at `end_us` (after the keys have come back up).
    pub fn finish(self, end_us: u64) -> (Performance, Stats, Counters) {
        let stats = *self.interp.stats();
        let counters = self.interp.counters();
        (
            self.robot.finish(Instant::from_micros(end_us)),
            stats,
            counters,
        )
    }
}
