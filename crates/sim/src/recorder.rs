//! The recorder: the whole performance, in a stable, comparable and serialisable form.
//!
//! A [`Performance`] holds every bus write, every pin edge and every sound event, in time
//! order, and [`Summary`] figures. Two performances are identical exactly when they are `==`.
//! It serialises with serde (times in nanoseconds) and prints as stable text
//! ([`Performance::to_text`], one line per record), for golden files and diffs.

use core::fmt;
use std::fmt::Write as _;

use serde::Serialize;

use crate::bus::{BusStats, BusWrite, SimTime};
use crate::mechanics::{MechanicsStats, Press, SoundEvent, SoundKind};

/// A driven pin of a board changed level (at the completion of the write that changed it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct PinEdge {
    /// When.
    pub time: SimTime,
    /// Index of the board, in configuration order (`u8::MAX` for a device attached to the bus
    /// by hand that is not in the configuration).
    pub board: u8,
    /// The board's 7-bit address.
    pub address: u8,
    /// Output bit, 0..=15 (0..=7 port 0).
    pub bit: u8,
    /// The key of this pin, or `None` for a pin no key is wired to.
    pub key: Option<u8>,
    /// Driven high (solenoid on) or not.
    pub high: bool,
}

/// Summary figures of a performance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct Summary {
    /// When the performance was closed.
    pub end: SimTime,
    /// Acknowledged write frames.
    pub writes: u64,
    /// Pin edges.
    pub edges: u64,
    /// Bus counters.
    pub bus: BusStats,
    /// Mechanics counters.
    pub mechanics: MechanicsStats,
}

/// Everything that happened, in time order.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct Performance {
    /// Every acknowledged bus write.
    pub writes: Vec<BusWrite>,
    /// Every change of a driven pin.
    pub edges: Vec<PinEdge>,
    /// Every key-down and key-up.
    pub sounds: Vec<SoundEvent>,
    /// Every press and what it gave, in the order the pins went low.
    pub presses: Vec<Press>,
    /// Per key: its key-down sounds (clean and smeared), counted whatever the robot keeps
    /// ([`Keep`](crate::Keep)).
    pub onsets: Vec<u64>,
    /// The figures.
    pub summary: Summary,
}

impl Performance {
    /// Key-down events that are clean onsets (not smeared).
    pub fn clean_onsets(&self) -> impl Iterator<Item = &SoundEvent> + '_ {
        self.sounds
            .iter()
            .filter(|e| e.kind == SoundKind::Down && !e.smeared)
    }

    /// Every event of one key.
    pub fn sounds_of(&self, key: u8) -> impl Iterator<Item = &SoundEvent> + '_ {
        self.sounds.iter().filter(move |e| e.key == key)
    }

    /// The stable text form: one line per write, edge and sound, then the summary.
    pub fn to_text(&self) -> String {
        self.to_string()
    }
}

impl fmt::Display for Performance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for w in &self.writes {
            let mut bytes = String::new();
            for (i, b) in w.bytes.iter().enumerate() {
                let sep = if i == 0 { "" } else { " " };
                let _ = write!(bytes, "{sep}{b:02x}");
            }
            write!(
                f,
                "write {}..{} @{:#04x} [{}] driven={:#06x}",
                w.start, w.end, w.address, bytes, w.driven
            )?;
            if let Some(duty) = &w.duty {
                write!(f, " duty={duty:?}")?;
            }
            writeln!(f)?;
        }
        for e in &self.edges {
            let key = e.key.map_or_else(|| "-".to_string(), |k| k.to_string());
            let level = if e.high { "high" } else { "low" };
            writeln!(
                f,
                "edge {} board {} @{:#04x} bit {} key {} {}",
                e.time, e.board, e.address, e.bit, key, level
            )?;
        }
        for s in &self.sounds {
            let kind = match s.kind {
                SoundKind::Down => "down",
                SoundKind::Up => "up",
            };
            let smear = if s.smeared { " smeared" } else { "" };
            writeln!(f, "sound {} key {} {}{}", s.time, s.key, kind, smear)?;
        }
        let s = &self.summary;
        let m = &s.mechanics;
        writeln!(
            f,
            "summary end={} writes={} edges={} transactions={} nacks={} bytes={} bit_times={} busy_ns={}",
            s.end, s.writes, s.edges, s.bus.transactions, s.bus.nacks, s.bus.bytes, s.bus.bit_times, s.bus.busy_nanos
        )?;
        writeln!(
            f,
            "summary clean_onsets={} smeared_presses={} smeared_onsets={} short_pulses={} key_ups={} stuck_at_end={} ignored_edges={}",
            m.clean_onsets, m.smeared_presses, m.smeared_onsets, m.short_pulses, m.key_ups, m.stuck_at_end, m.ignored_edges
        )
    }
}

/// Collects writes and edges while the robot plays; [`finish`](Self::finish) adds the sounds
/// and the figures.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Recorder {
    writes: Vec<BusWrite>,
    edges: Vec<PinEdge>,
    write_count: u64,
    edge_count: u64,
}

impl Recorder {
    /// Nothing recorded yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records a bus write.
    pub fn record_write(&mut self, write: BusWrite) {
        self.writes.push(write);
        self.write_count += 1;
    }

    /// Records a pin edge.
    pub fn record_edge(&mut self, edge: PinEdge) {
        self.edges.push(edge);
        self.edge_count += 1;
    }

    /// Counts writes without keeping them.
    pub fn count_writes(&mut self, n: usize) {
        self.write_count += n as u64;
    }

    /// Counts edges without keeping them.
    pub fn count_edges(&mut self, n: usize) {
        self.edge_count += n as u64;
    }

    /// The writes so far.
    pub fn writes(&self) -> &[BusWrite] {
        &self.writes
    }

    /// The edges so far.
    pub fn edges(&self) -> &[PinEdge] {
        &self.edges
    }

    /// The performance: what was recorded, `sounds` (sorted by time, as
    /// [`Mechanics::finish`](crate::Mechanics::finish) returns them) and the figures.
    pub fn finish(
        self,
        end: SimTime,
        sounds: Vec<SoundEvent>,
        presses: Vec<Press>,
        bus: BusStats,
        mechanics: MechanicsStats,
    ) -> Performance {
        let summary = Summary {
            end,
            writes: self.write_count,
            edges: self.edge_count,
            bus,
            mechanics,
        };
        Performance {
            writes: self.writes,
            edges: self.edges,
            sounds,
            presses,
            onsets: Vec::new(),
            summary,
        }
    }
}
