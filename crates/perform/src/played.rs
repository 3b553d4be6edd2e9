//! A finished performance: every note's record, what the virtual robot did, and the report.

use orch_core::Stats;
use orch_sim::Performance;

use crate::ledger::{NoteRecord, Outcome};
use crate::plan::PlanStats;
use crate::report::{Bus, GroupReport, Outcomes, Report, Spread, VelocityError};

/// How far a struck note's loudness may be from its velocity, in MIDI velocity steps, before
/// `orch analyze` names it as too loud or too soft for the robot.
pub const VELOCITY_TOLERANCE: u8 = 2;

/// A finished performance: every note's record and what the virtual robot did.
#[derive(Debug)]
pub struct Played {
    /// Every score note, in score order (its index is its [`NoteId`](crate::NoteId)), with its
    /// outcome.
    pub records: Vec<NoteRecord>,
    /// What the virtual robot did: writes, edges, sounds, presses.
    pub performance: Performance,
    /// The interpreter's counters.
    pub stats: Stats,
    /// What the planner changed.
    pub plan: PlanStats,
    /// Real-clock lateness of each message sent, µs (real-time play only).
    pub lateness_us: Option<Vec<u64>>,
    /// Real-clock lateness of each record's Note-On, µs, indexed as [`records`](Self::records)
    /// (real-time play only; `None` for a note not sent). The same sends as
    /// [`lateness_us`](Self::lateness_us), tied to their notes.
    pub note_lateness_us: Option<Vec<Option<u32>>>,
    /// When the song started (score time 0), wall µs.
    pub start_us: u64,
    /// When the robot had finished, wall µs.
    pub end_us: u64,
    /// Re-strikes that waited for their key's rest.
    pub restrikes_waited: u64,
    /// Whether it was stopped before the end.
    pub stopped: bool,
    /// Jumps taken ([`Control::jump_to`](crate::Control::jump_to)).
    pub jumps: u64,
    /// Notes the performance came to again after a jump back: `records` holds the score's
    /// notes plus these (each pass over a note is a record of its own).
    pub replayed: u64,
    /// Per key: whether velocity is played there (a PWM key), for the velocity error.
    pub dynamic_keys: Vec<bool>,
    /// Per key: whether it is a lead or a damper (an open hi-hat's lift, a bar's damper): an
    /// output no note strikes itself, whose presses are not notes' strikes.
    pub extra_keys: Vec<bool>,
    /// Per key: whether it is a wind robot's finger (its notes sound on its valve).
    pub finger_keys: Vec<bool>,
    /// The robot's groups, each its name and outputs, if it has more than one (see
    /// [`Setup::groups`](crate::Setup::groups)).
    pub groups: Vec<(String, std::ops::Range<u8>)>,
}

impl Played {
    /// The report, with `uncompensated` (the onset error of the same piece played without
    /// compensation) beside it if given.
    pub fn report(&self, uncompensated: Option<Spread>) -> Report {
        let (outcomes, unmatched) = Outcomes::of(&self.records);
        let mut folded_by_octaves = std::collections::BTreeMap::new();
        for r in &self.records {
            if let Some(l) = r.landing.filter(|l| l.octaves != 0) {
                *folded_by_octaves.entry(l.octaves).or_insert(0) += 1;
            }
        }
        let m = self.performance.summary.mechanics;
        let bus = self.performance.summary.bus;
        let span = self.end_us.saturating_sub(self.start_us).max(1) as f64;
        let s = &self.stats;
        // Counted per key by the mechanics: the sounds themselves are not kept on a long
        // performance (`Keep::Presses`).
        let downs_of = |keys: &[bool]| {
            let onsets = self.performance.onsets.iter().zip(keys);
            onsets.filter(|(_, &is)| is).map(|(n, _)| n).sum::<u64>()
        };
        let lifts_and_dampers = downs_of(&self.extra_keys);
        let fingers = downs_of(&self.finger_keys);
        Report {
            notes: (self.records.len() as u64).saturating_sub(self.replayed),
            jumps: self.jumps,
            replayed: self.replayed,
            outcomes,
            strikes: m.clean_onsets + m.smeared_onsets - lifts_and_dampers - fingers,
            lifts_and_dampers,
            fingers,
            unmatched,
            folded: folded_by_octaves.values().sum(),
            folded_by_octaves,
            restrikes_delayed: self.restrikes_waited,
            planning: self.plan.into(),
            cut_by_hold_limit: s.cut_by_hold_limit.into(),
            cut_by_duty_limit: s.cut_by_duty_limit.into(),
            cut_by_watchdog: s.cut_by_watchdog.into(),
            onset_ms: Spread::of_onsets(&self.records),
            onset_uncompensated_ms: uncompensated,
            velocity_error: VelocityError::of(&self.records, |key| {
                self.dynamic_keys.get(key as usize) == Some(&true)
            }),
            peak_keys_down: s.peak_keys_down,
            too_short_to_sound: m.short_pulses,
            smeared: m.smeared_presses,
            muted: m.muted,
            bus: Bus {
                writes: bus.transactions,
                bytes: bus.bytes,
                busy_percent: (bus.busy_nanos as f64 / 1000.0 / span * 100_000.0).round() / 1000.0,
            },
            seconds: (span / 1e4).round() / 100.0,
            lateness_ms: self.lateness_us.as_ref().map(|l| {
                let mut ms: Vec<f64> = l.iter().map(|&u| u as f64 / 1000.0).collect();
                Spread::of(&mut ms)
            }),
            groups: self.group_reports(),
        }
    }

    /// How each group fared: its notes (those that landed on its outputs) and their outcomes.
    fn group_reports(&self) -> Vec<GroupReport> {
        self.groups
            .iter()
            .map(|(name, keys)| {
                let mine: Vec<NoteRecord> = self
                    .records
                    .iter()
                    .filter(|r| r.landing.is_some_and(|l| keys.contains(&l.key)))
                    .copied()
                    .collect();
                let (outcomes, unmatched) = Outcomes::of(&mine);
                GroupReport {
                    name: name.clone(),
                    notes: mine.len() as u64,
                    outcomes,
                    unmatched,
                    onset_ms: Spread::of_onsets(&mine),
                }
            })
            .collect()
    }

    /// Whether `r` struck on a PWM key and sounded louder (`Some(true)`) or softer
    /// (`Some(false)`) than its velocity by more than [`VELOCITY_TOLERANCE`] steps.
    pub fn loudness_off(&self, r: &NoteRecord) -> Option<bool> {
        let key = r.landing?.key;
        if self.dynamic_keys.get(usize::from(key)) != Some(&true) || r.outcome.error_ms().is_none()
        {
            return None;
        }
        let heard = r.sounded_velocity?;
        (heard.abs_diff(r.velocity) > VELOCITY_TOLERANCE).then_some(heard > r.velocity)
    }

    /// The notes that went wrong, the worst first: dropped (too soft among them), struck
    /// without a sound, joined, late and early by how much, then those that sounded louder or
    /// softer than asked by more than [`VELOCITY_TOLERANCE`] steps, by how much.
    pub fn went_wrong(&self) -> Vec<&NoteRecord> {
        let rank = |r: &NoteRecord| -> (u8, i64) {
            match r.outcome {
                Outcome::Dropped(_) => (0, 0),
                Outcome::Unmatched => (1, 0),
                Outcome::Joined => (2, 0),
                Outcome::Late { by_us } | Outcome::Early { by_us } => (3, -i64::from(by_us)),
                _ if self.loudness_off(r).is_some() => (
                    4,
                    -i64::from(r.sounded_velocity.unwrap_or(0).abs_diff(r.velocity)),
                ),
                _ => (9, 0),
            }
        };
        let mut v: Vec<&NoteRecord> = self.records.iter().filter(|r| rank(r).0 < 9).collect();
        v.sort_by_key(|r| (rank(r), r.score_at_us));
        v
    }
}
