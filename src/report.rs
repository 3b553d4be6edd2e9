//! The report of a performance: what was played, what was not and why, and how on time.

use std::collections::BTreeMap;

use orch_sim::SoundKind;
use serde::Serialize;

use crate::perform::{NoteRecord, Outcome};

/// Median, 99th percentile and largest of a set of figures, in ms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    pub median: f64,
    pub p99: f64,
    pub max: f64,
}

impl Spread {
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
}

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Dropped {
    /// On a channel the robot does not listen to.
    pub channel: u32,
    /// Outside the keys, with the drop policy.
    pub range: u32,
    /// Past the power budget (keys down at once).
    pub power: u32,
    /// Waiting for a re-strike when everything was released.
    pub cancelled: u32,
}

/// The report, as printed and as JSON.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub notes: u64,
    pub played: u32,
    pub folded: u32,
    /// Folded notes by octaves moved (+ up, − down).
    pub folded_by_octaves: BTreeMap<i8, u32>,
    pub dropped: Dropped,
    pub restrikes_delayed: u32,
    pub cut_by_hold_limit: u32,
    pub cut_by_watchdog: u32,
    /// |sound − score| of each note that sounded, with latency compensation as played.
    pub onset_ms: Spread,
    /// The same without compensation, for comparison.
    pub onset_uncompensated_ms: Spread,
    pub peak_keys_down: u8,
    /// Presses too short for the key to sound (shorter than its min_hold).
    pub too_short_to_sound: u64,
    /// Presses that came before the key was back up.
    pub smeared: u64,
    /// Notes that sounded (key-down events).
    pub onsets: usize,
    pub bus: Bus,
    pub seconds: f64,
    /// Real-clock lateness of each message sent, in ms (real-time play only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lateness_ms: Option<Spread>,
}

#[derive(Clone, Debug, Serialize)]
pub struct Bus {
    pub writes: u64,
    pub bytes: u64,
    /// Share of the piece the bus was busy, in percent.
    pub busy_percent: f64,
}

/// Matches each note that struck its key to the key-down sound it made, key by key, and
/// returns the (sound − score) error of each match in ms, with the note.
pub fn onset_errors(outcome: &Outcome) -> Vec<(NoteRecord, f64)> {
    let mut by_key: BTreeMap<u8, Vec<NoteRecord>> = BTreeMap::new();
    for n in &outcome.notes {
        if let (Some(k), true) = (n.key, n.strikes) {
            by_key.entry(k).or_default().push(*n);
        }
    }
    let mut out = Vec::new();
    for (key, score) in by_key {
        let sounds: Vec<f64> = outcome
            .performance
            .sounds_of(key)
            .filter(|s| s.kind == SoundKind::Down && !s.smeared)
            .map(|s| s.time.as_nanos() as f64 / 1000.0)
            .collect();
        // In order: each strike takes the first sound not yet taken that comes no earlier
        // than 1 ms before its score time (compensation can land a hair early).
        // A sound after the next strike's score time is that strike's, not this one's.
        let mut next = 0;
        for (i, n) in score.iter().enumerate() {
            let at = n.score_us as f64;
            let before = score
                .get(i + 1)
                .map_or(f64::INFINITY, |m| m.score_us as f64);
            while next < sounds.len() && sounds[next] < at - 1_000.0 {
                next += 1;
            }
            if let Some(&t) = sounds.get(next).filter(|&&t| t < before.max(at + 1_000.0)) {
                out.push((*n, (t - at) / 1000.0));
                next += 1;
            }
        }
    }
    out
}

impl Report {
    pub fn new(notes: u64, played: &Outcome, uncompensated: &Outcome) -> Self {
        let s = played.stats;
        let mut folded_by_octaves = BTreeMap::new();
        for n in &played.notes {
            if n.key.is_some() && n.octaves != 0 {
                *folded_by_octaves.entry(n.octaves).or_insert(0) += 1;
            }
        }
        let spread = |o: &Outcome| {
            let mut e: Vec<f64> = onset_errors(o).into_iter().map(|(_, e)| e.abs()).collect();
            Spread::of(&mut e)
        };
        let m = played.performance.summary.mechanics;
        let bus = played.performance.summary.bus;
        let span = (played.end_us.saturating_sub(played.start_us)).max(1) as f64;
        Report {
            notes,
            played: s.played,
            folded: s.folded,
            folded_by_octaves,
            dropped: Dropped {
                channel: s.dropped_channel,
                range: s.dropped_range,
                power: s.dropped_power,
                cancelled: s.dropped_cancelled,
            },
            restrikes_delayed: s.restrikes_delayed,
            cut_by_hold_limit: s.cut_by_hold_limit,
            cut_by_watchdog: s.cut_by_watchdog,
            onset_ms: spread(played),
            onset_uncompensated_ms: spread(uncompensated),
            peak_keys_down: s.peak_keys_down,
            too_short_to_sound: m.short_pulses,
            smeared: m.smeared_presses,
            onsets: played.performance.clean_onsets().count(),
            bus: Bus {
                writes: bus.transactions,
                bytes: bus.bytes,
                busy_percent: (bus.busy_nanos as f64 / 1000.0 / span * 100_000.0).round() / 1000.0,
            },
            seconds: (span / 1e4).round() / 100.0,
            lateness_ms: played.lateness.map(|l| Spread {
                median: l.median_us as f64 / 1000.0,
                p99: l.p99_us as f64 / 1000.0,
                max: l.max_us as f64 / 1000.0,
            }),
        }
    }

    /// Notes accounted for: played + folded + every drop.
    pub fn accounted(&self) -> u64 {
        let d = &self.dropped;
        (self.played + self.folded + d.channel + d.range + d.power + d.cancelled) as u64
    }

    pub fn text(&self) -> String {
        let d = &self.dropped;
        let octaves: Vec<String> = self
            .folded_by_octaves
            .iter()
            .map(|(o, n)| format!("{n} by {o:+} octave{}", if o.abs() == 1 { "" } else { "s" }))
            .collect();
        let mut t = String::new();
        let mut line = |s: String| {
            t.push_str(&s);
            t.push('\n');
        };
        line(format!("notes in the file      {}", self.notes));
        line(format!("played                 {}", self.played));
        line(format!(
            "folded                 {}{}",
            self.folded,
            if octaves.is_empty() {
                String::new()
            } else {
                format!(" ({})", octaves.join(", "))
            }
        ));
        line(format!(
            "dropped                {} (channel {}, range {}, power budget {}, cancelled {})",
            d.channel + d.range + d.power + d.cancelled,
            d.channel,
            d.range,
            d.power,
            d.cancelled
        ));
        line(format!("re-strikes delayed     {}", self.restrikes_delayed));
        line(format!("cut by the hold limit  {}", self.cut_by_hold_limit));
        if self.cut_by_watchdog > 0 {
            line(format!("cut by the watchdog    {}", self.cut_by_watchdog));
        }
        let sp = |s: &Spread| {
            format!(
                "median {:.3}, p99 {:.3}, max {:.3} ms",
                s.median, s.p99, s.max
            )
        };
        line(format!("onset error            {}", sp(&self.onset_ms)));
        line(format!(
            "  without compensation {}",
            sp(&self.onset_uncompensated_ms)
        ));
        line(format!("peak keys down         {}", self.peak_keys_down));
        line(format!(
            "too short to sound     {}   smeared presses {}",
            self.too_short_to_sound, self.smeared
        ));
        line(format!(
            "bus                    {} writes, {} bytes, busy {:.3}% of {:.1} s",
            self.bus.writes, self.bus.bytes, self.bus.busy_percent, self.seconds
        ));
        if let Some(l) = &self.lateness_ms {
            line(format!("real-clock lateness    {}", sp(l)));
        }
        t
    }
}
