//! The report of a performance: every note's outcome, how on time, and what the robot did.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::ledger::{NoteRecord, Outcome};
use crate::plan::PlanStats;

/// Median, 99th percentile and largest of a set of figures, in ms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    /// The median.
    pub median: f64,
    /// The 99th percentile (nearest rank).
    pub p99: f64,
    /// The largest.
    pub max: f64,
}

impl Spread {
    /// The spread of `values` (reordered).
    pub fn of(values: &mut [f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        values.sort_by(f64::total_cmp);
        let rank = |p: f64| {
            let r = (p * values.len() as f64).ceil() as usize;
            values[r.clamp(1, values.len()) - 1]
        };
        let round = |x: f64| (x * 1000.0).round() / 1000.0;
        Self {
            median: round(rank(0.5)),
            p99: round(rank(0.99)),
            max: round(values[values.len() - 1]),
        }
    }

    /// The onset errors |sound − score| of the struck notes of `records`, in ms.
    pub fn of_onsets(records: &[NoteRecord]) -> Self {
        let mut e: Vec<f64> = records
            .iter()
            .filter_map(|r| r.outcome.error_ms())
            .collect();
        Self::of(&mut e)
    }
}

/// How far the loudness of struck notes was from their velocity: |sounded − asked|, in MIDI
/// velocity steps, median, 95th percentile (nearest rank) and largest.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct VelocityError {
    /// The median.
    pub median: u8,
    /// The 95th percentile.
    pub p95: u8,
    /// The largest.
    pub max: u8,
    /// Struck notes that sounded louder than asked by more than
    /// [`VELOCITY_TOLERANCE`](crate::VELOCITY_TOLERANCE) (2) steps.
    pub louder: u64,
    /// Struck notes that sounded softer than asked by more than 2 steps.
    pub softer: u64,
}

impl VelocityError {
    /// Over the notes of `records` whose own strike sounded on a key for which `dynamic` says
    /// velocity counts (a PWM key); `None` if there are none.
    pub fn of(records: &[NoteRecord], dynamic: impl Fn(u8) -> bool) -> Option<Self> {
        let mut louder = 0;
        let mut softer = 0;
        let mut e: Vec<u8> = records
            .iter()
            .filter(|r| r.outcome.error_ms().is_some() && r.landing.is_some_and(|l| dynamic(l.key)))
            .filter_map(|r| {
                let heard = r.sounded_velocity?;
                let off = heard.abs_diff(r.velocity) > crate::VELOCITY_TOLERANCE;
                louder += u64::from(off && heard > r.velocity);
                softer += u64::from(off && heard < r.velocity);
                Some(heard.abs_diff(r.velocity))
            })
            .collect();
        if e.is_empty() {
            return None;
        }
        e.sort_unstable();
        let rank = |p: f64| e[((p * e.len() as f64).ceil() as usize).clamp(1, e.len()) - 1];
        Some(Self {
            median: rank(0.5),
            p95: rank(0.95),
            max: e[e.len() - 1],
            louder,
            softer,
        })
    }
}

/// Notes dropped, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Dropped {
    /// On a channel the robot does not listen to.
    pub channel: u64,
    /// On channel 10 (General MIDI's drums), which no group of the robot listens to.
    pub percussion: u64,
    /// A strike group listens to its channel but has no output for it.
    pub unmapped: u64,
    /// Outside the keys, with the drop policy.
    pub range: u64,
    /// Past the power budget.
    pub power: u64,
    /// A re-strike that could not sound within `late_limit` (on a fingered group: a note
    /// released before its fingers settled, taken over by the next).
    pub too_fast: u64,
    /// A chord's note a one-voice (fingered) group did not play.
    pub monophonic: u64,
    /// Struck too softly to sound: its duty below the key's softest (PWM keys only).
    pub too_soft: u64,
    /// A wind note that cracked: its valve opened before its fingers settled, or a finger
    /// moved while it sounded (the virtual robot says so; orch's interlock prevents it).
    pub cracked: u64,
    /// A waiting re-strike cancelled (taken over, reset, watchdog).
    pub cancelled: u64,
    /// Not played because the performance was stopped.
    pub stopped: u64,
}

impl Dropped {
    /// Every drop.
    pub fn total(&self) -> u64 {
        self.channel
            + self.percussion
            + self.unmapped
            + self.range
            + self.power
            + self.too_fast
            + self.monophonic
            + self.too_soft
            + self.cracked
            + self.cancelled
            + self.stopped
    }
}

/// One count per outcome: they add up to the notes in the score.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Outcomes {
    /// Its own strike sounded within 1 ms of its score time.
    pub on_time: u64,
    /// Its own strike sounded later than that.
    pub late: u64,
    /// Its own strike sounded more than 1 ms early (0 unless the robot's figures are wrong).
    pub early: u64,
    /// Struck together with another note on the same key at the same instant.
    pub unison: u64,
    /// The key was already down for another note.
    pub joined: u64,
    /// Not played, by reason.
    pub dropped: Dropped,
    /// Passed over by a jump ([`Outcome::Skipped`]).
    pub skipped: u64,
}

impl Outcomes {
    /// The counts of `records`; unmatched notes are counted apart.
    pub fn of(records: &[NoteRecord]) -> (Self, u64) {
        let mut o = Outcomes::default();
        let mut unmatched = 0;
        for r in records {
            match r.outcome {
                Outcome::OnTime { .. } => o.on_time += 1,
                Outcome::Late { .. } => o.late += 1,
                Outcome::Early { .. } => o.early += 1,
                Outcome::Unison => o.unison += 1,
                Outcome::Joined => o.joined += 1,
                Outcome::Unmatched => unmatched += 1,
                Outcome::Skipped => o.skipped += 1,
                Outcome::Dropped(reason) => {
                    let d = &mut o.dropped;
                    *match reason {
                        orch_core::DropReason::Channel => &mut d.channel,
                        orch_core::DropReason::Percussion => &mut d.percussion,
                        orch_core::DropReason::Unmapped => &mut d.unmapped,
                        orch_core::DropReason::Range => &mut d.range,
                        orch_core::DropReason::Power => &mut d.power,
                        orch_core::DropReason::TooFast => &mut d.too_fast,
                        orch_core::DropReason::Monophonic => &mut d.monophonic,
                        orch_core::DropReason::Cancelled => &mut d.cancelled,
                        orch_core::DropReason::Stopped => &mut d.stopped,
                        orch_core::DropReason::TooSoft => &mut d.too_soft,
                        orch_core::DropReason::Cracked => &mut d.cracked,
                    } += 1;
                }
            }
        }
        (o, unmatched)
    }

    /// Notes accounted for (unmatched ones aside).
    pub fn total(&self) -> u64 {
        self.on_time
            + self.late
            + self.early
            + self.unison
            + self.joined
            + self.dropped.total()
            + self.skipped
    }
}

/// What the planner changed to keep its rules.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Planning {
    /// Releases moved earlier so a re-strike gets its rest.
    pub releases_moved_early: u64,
    /// Note-Offs added so a re-strike lands on time (`overlap = "restrike"`).
    pub early_releases_added: u64,
    /// Presses sent later than their lead, behind the key's earlier messages.
    pub presses_held_back: u64,
    /// Channel-wide controllers moved to keep their place among their channel's notes.
    pub controllers_moved: u64,
}

impl From<PlanStats> for Planning {
    fn from(s: PlanStats) -> Self {
        Self {
            releases_moved_early: s.releases_moved_early,
            early_releases_added: s.early_releases_added,
            presses_held_back: s.presses_held_back,
            controllers_moved: s.controllers_moved,
        }
    }
}

/// The bus.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Bus {
    /// Board writes.
    pub writes: u64,
    /// Bytes on the bus.
    pub bytes: u64,
    /// Share of the piece the bus was busy, in percent.
    pub busy_percent: f64,
}

/// The report, as printed and as JSON.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Notes (Note-Ons) in the score.
    pub notes: u64,
    /// Jumps taken (to a bar, a song position, the top).
    pub jumps: u64,
    /// Notes played again after a jump back: each pass over a note has its own outcome, so
    /// the outcomes add up to `notes + replayed`.
    pub replayed: u64,
    /// What became of them: one count per outcome.
    pub outcomes: Outcomes,
    /// Key-down sounds of the virtual robot: the notes' strikes (lifts and dampers apart).
    pub strikes: u64,
    /// Presses of lead outputs (an open hi-hat's lift) and dampers on the virtual robot: no
    /// note's own strike. With `strikes`, every key-down of the virtual robot.
    pub lifts_and_dampers: u64,
    /// Presses of a wind robot's fingers (its notes sound on its valve, in `strikes`). With
    /// `strikes` and `lifts_and_dampers`, every key-down of the virtual robot.
    pub fingers: u64,
    /// Notes that struck but made no sound (must be 0).
    pub unmatched: u64,
    /// Notes folded into the keys, whatever became of them.
    pub folded: u64,
    /// Folded notes by octaves moved (+ up, − down).
    pub folded_by_octaves: BTreeMap<i8, u64>,
    /// Re-strikes the interpreter held back for their key's rest that then struck, late
    /// (those whose wait was cancelled or stopped are counted under `outcomes.dropped`).
    pub restrikes_delayed: u64,
    /// What the planner changed.
    pub planning: Planning,
    /// Keys released by the hold limit.
    pub cut_by_hold_limit: u64,
    /// Keys released by the duty limit.
    pub cut_by_duty_limit: u64,
    /// Keys released by the watchdog.
    pub cut_by_watchdog: u64,
    /// |sound − score| of every struck note, ms.
    pub onset_ms: Spread,
    /// The same without latency compensation, for comparison.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub onset_uncompensated_ms: Option<Spread>,
    /// How far each struck note's loudness was from its velocity, on a robot with PWM keys
    /// (`null` on an on/off robot, which ignores velocity).
    pub velocity_error: Option<VelocityError>,
    /// The most keys down at once.
    pub peak_keys_down: u8,
    /// Presses too short for the key to sound.
    pub too_short_to_sound: u64,
    /// Presses that came before the key was back up.
    pub smeared: u64,
    /// Strikes whose beater stayed on its drum head or bar long enough to choke it.
    pub muted: u64,
    /// The bus.
    pub bus: Bus,
    /// The length of the performance, s.
    pub seconds: f64,
    /// Real-clock lateness of each message sent, ms (real-time play only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lateness_ms: Option<Spread>,
    /// How each group of a robot with several (a piano, a kit, a recorder) fared; absent for
    /// a robot of one group. A note is its group's if it landed on one of its outputs; notes
    /// that landed nowhere (a channel no group listens to) are no group's.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub groups: Vec<GroupReport>,
}

/// How one group of the robot fared.
#[derive(Clone, Debug, Serialize)]
pub struct GroupReport {
    /// Its name (robot.toml's; "keyboard" for the keys).
    pub name: String,
    /// The notes that landed on its outputs.
    pub notes: u64,
    /// What became of them.
    pub outcomes: Outcomes,
    /// Those that struck but made no sound.
    pub unmatched: u64,
    /// |sound − score| of its struck notes, ms.
    pub onset_ms: Spread,
}

impl GroupReport {
    /// One line of the text report.
    fn line(&self) -> String {
        let o = &self.outcomes;
        format!(
            "group {:<16} {} notes: {} on time, {} late, {} early, {} unison, {} joined, {} dropped; onset error median {:.3}, max {:.3} ms",
            self.name,
            self.notes,
            o.on_time,
            o.late,
            o.early,
            o.unison,
            o.joined,
            o.dropped.total(),
            self.onset_ms.median,
            self.onset_ms.max
        )
    }
}

impl Report {
    /// Whether the outcomes add up: every note counted once, every strike a struck note's.
    pub fn adds_up(&self) -> bool {
        self.outcomes.total() + self.unmatched == self.notes + self.replayed
            && self.strikes == self.outcomes.on_time + self.outcomes.late + self.outcomes.early
    }

    /// The report as text, a line a figure.
    pub fn text(&self) -> String {
        let o = &self.outcomes;
        let d = &o.dropped;
        let octaves: Vec<String> = self
            .folded_by_octaves
            .iter()
            .map(|(k, n)| format!("{n} by {k:+} octave{}", if k.abs() == 1 { "" } else { "s" }))
            .collect();
        let sp = |s: &Spread| {
            format!(
                "median {:.3}, p99 {:.3}, max {:.3} ms",
                s.median, s.p99, s.max
            )
        };
        let mut t = String::new();
        let mut line = |s: String| {
            t.push_str(&s);
            t.push('\n');
        };
        line(format!("notes in the file      {}", self.notes));
        line(format!(
            "struck on time         {}   (its own strike within 1 ms of the score)",
            o.on_time
        ));
        line(format!("struck late            {}", o.late));
        if o.early > 0 {
            line(format!("struck early           {}", o.early));
        }
        line(format!(
            "unison                 {}   (struck together with another note on the key)",
            o.unison
        ));
        line(format!(
            "joined                 {}   (its key was already held for another note: no strike of its own)",
            o.joined
        ));
        // Too soft only where velocity plays (a robot with PWM keys), or if any was.
        let too_soft = if self.velocity_error.is_some() || d.too_soft > 0 {
            format!(", too soft {}", d.too_soft)
        } else {
            String::new()
        };
        // Drum notes only where there were any.
        let mut drums = String::new();
        if d.percussion > 0 {
            drums += &format!(", drums on channel 10 {}", d.percussion);
        }
        if d.unmapped > 0 {
            drums += &format!(", no drum for it {}", d.unmapped);
        }
        if d.monophonic > 0 {
            drums += &format!(", one voice plays another {}", d.monophonic);
        }
        if d.cracked > 0 {
            drums += &format!(
                ", cracked {} (the valve opened before the fingers settled)",
                d.cracked
            );
        }
        line(format!(
            "dropped                {} (channel {}{drums}, range {}, power budget {}, too fast {}{too_soft}, cancelled {}, stopped {})",
            d.total(),
            d.channel,
            d.range,
            d.power,
            d.too_fast,
            d.cancelled,
            d.stopped
        ));
        if self.unmatched > 0 {
            line(format!("struck but no sound    {}", self.unmatched));
        }
        if self.jumps > 0 {
            line(format!(
                "jumps                  {}: {} notes skipped, {} played again after a jump back",
                self.jumps, o.skipped, self.replayed
            ));
        }
        line(format!("strikes heard          {}", self.strikes));
        if self.lifts_and_dampers > 0 {
            line(format!(
                "lifts and dampers      {}   (outputs no note strikes: an open hi-hat's lift, a damper)",
                self.lifts_and_dampers
            ));
        }
        line(format!(
            "folded                 {}{}",
            self.folded,
            if octaves.is_empty() {
                String::new()
            } else {
                format!(" ({})", octaves.join(", "))
            }
        ));
        let p = &self.planning;
        line(format!(
            "re-strikes             {} struck late after waiting for the key's rest; {} releases moved early, {} added",
            self.restrikes_delayed, p.releases_moved_early, p.early_releases_added
        ));
        line(format!(
            "cut                    {} by the hold limit, {} by the duty limit, {} by the watchdog",
            self.cut_by_hold_limit, self.cut_by_duty_limit, self.cut_by_watchdog
        ));
        line(format!("onset error            {}", sp(&self.onset_ms)));
        if let Some(v) = &self.velocity_error {
            line(format!(
                "velocity error         median {}, p95 {}, max {} steps ({} louder, {} softer than asked by more than 2)",
                v.median, v.p95, v.max, v.louder, v.softer
            ));
        }
        if let Some(u) = &self.onset_uncompensated_ms {
            line(format!("  without compensation {}", sp(u)));
        }
        line(format!("peak keys down         {}", self.peak_keys_down));
        line(format!(
            "too short to sound     {}   smeared presses {}",
            self.too_short_to_sound, self.smeared
        ));
        if self.muted > 0 {
            line(format!(
                "muted strikes          {}   (a beater left on its head or bar)",
                self.muted
            ));
        }
        line(format!(
            "bus                    {} writes, {} bytes, busy {:.3}% of {:.1} s",
            self.bus.writes, self.bus.bytes, self.bus.busy_percent, self.seconds
        ));
        if let Some(l) = &self.lateness_ms {
            line(format!("real-clock lateness    {} per message sent", sp(l)));
        }
        for g in &self.groups {
            line(g.line());
        }
        t
    }
}
