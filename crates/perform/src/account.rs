//! The note-by-note account of a performance: one line for every note of the score, in score
//! order, saying what became of it. What `--notes` writes and a piano roll or a web page draws
//! from; its counts are the report's.

use serde::Serialize;

use crate::ledger::{NoteRecord, Outcome};
use crate::played::Played;

/// One note of the account (`orch play --notes`, `orch analyze --notes`), as one JSON object:
///
/// `{"t_ms":T,"bar":B,"beat":X,"note":N,"channel":C,"velocity":V,"key":K,"outcome":O,
/// "reason":R,"sent_ms":S,"sent_late_ms":L,"sounded_ms":H,"onset_ms":E,"sounded_velocity":W}`
///
/// Times are ms from the start of the performance (score time 0). `reason` is there only for
/// a dropped note, `sent_late_ms` only for a note sent in real time; `sent_ms`, `sounded_ms`,
/// `onset_ms` and `sounded_velocity` are `null` where there is none (a note never sent; a note
/// with no strike of its own: joined, unison, dropped, skipped).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NoteLine {
    /// When the score wants it to sound, ms.
    pub t_ms: f64,
    /// Its bar, counted from 1 by the file's time signatures (4/4 until the first).
    pub bar: u32,
    /// Its beat in the bar, from 1.
    pub beat: u32,
    /// The MIDI note number, as written (before any folding).
    pub note: u8,
    /// Its channel, 1..=16 as people count them.
    pub channel: u8,
    /// Its velocity in the file.
    pub velocity: u8,
    /// The output it landed on, `null` if none: the robot's outputs are numbered from 0 in
    /// board order, the keyboard's keys first (0 = its lowest), then each strike group's
    /// outputs (a kit's in the order robot.toml lists them, a glockenspiel's bars lowest
    /// first).
    pub key: Option<u8>,
    /// `on_time`, `late`, `early`, `unison`, `joined`, `dropped`, `unmatched` or `skipped`
    /// (the report's outcomes).
    pub outcome: &'static str,
    /// Why it was dropped (`channel`, `percussion`, `unmapped`, `range`, `power`, `too_fast`,
    /// `too_soft`, `cracked`, `cancelled`, `stopped`); only for `dropped`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<&'static str>,
    /// When its Note-On was sent, ms.
    pub sent_ms: Option<f64>,
    /// How much later than `sent_ms` its Note-On left by the real clock, ms (the host's
    /// delay: a thread woken late, a busy CPU, an emulator); real-time play only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sent_late_ms: Option<f64>,
    /// When its own strike sounded, ms.
    pub sounded_ms: Option<f64>,
    /// Sounded − score, ms (positive: late).
    pub onset_ms: Option<f64>,
    /// How loud its own strike sounded, on the MIDI velocity scale.
    pub sounded_velocity: Option<u8>,
}

/// The outcome's word in the account, and the reason of a drop.
fn words(o: Outcome) -> (&'static str, Option<&'static str>) {
    match o {
        Outcome::Dropped(r) => ("dropped", Some(r.name())),
        o => (o.name(), None),
    }
}

/// ms, rounded to the µs.
fn ms(us: i64) -> f64 {
    us as f64 / 1000.0
}

impl Played {
    /// The account: one line for every record (every score note, and every note played again
    /// after a jump back), in score order. `bar_beat` gives a note's bar and beat from its
    /// record's index in [`records`](Self::records) and its time in ms from the start of the
    /// performance (the front end knows the song, its notes and the tempo it was played at).
    pub fn account(&self, bar_beat: impl Fn(usize, f64) -> (u32, u32)) -> Vec<NoteLine> {
        self.account_indexed(bar_beat)
            .into_iter()
            .map(|(_, l)| l)
            .collect()
    }

    /// The [`account`](Self::account), each line with the index of its record in
    /// [`records`](Self::records) (for a score's note, its place among the song's Note-Ons:
    /// what ties a line to its note's Note-Off, for a piano roll).
    pub fn account_indexed(
        &self,
        bar_beat: impl Fn(usize, f64) -> (u32, u32),
    ) -> Vec<(usize, NoteLine)> {
        let start = self.start_us as i64;
        let mut lines: Vec<(i64, usize, NoteLine)> = self
            .records
            .iter()
            .enumerate()
            .map(|(i, r)| (r.score_at_us, i, self.line(i, r, start, &bar_beat)))
            .collect();
        // Score order: by time, and in the file's order at the same time (a record's index is
        // its note's place among the Note-Ons).
        lines.sort_by_key(|(t, i, _)| (*t, *i));
        lines.into_iter().map(|(_, i, l)| (i, l)).collect()
    }

    fn line(
        &self,
        i: usize,
        r: &NoteRecord,
        start: i64,
        bar_beat: &impl Fn(usize, f64) -> (u32, u32),
    ) -> NoteLine {
        let t_ms = ms(r.score_at_us - start);
        let (bar, beat) = bar_beat(i, t_ms.max(0.0));
        let (outcome, reason) = words(r.outcome);
        let onset_us = match r.outcome {
            Outcome::OnTime { error_us } => Some(i64::from(error_us)),
            Outcome::Late { by_us } => Some(i64::from(by_us)),
            Outcome::Early { by_us } => Some(-i64::from(by_us)),
            _ => None,
        };
        NoteLine {
            t_ms,
            bar,
            beat,
            note: r.note,
            channel: r.channel + 1,
            velocity: r.velocity,
            key: r.landing.map(|l| l.key),
            outcome,
            reason,
            sent_ms: r.sent_us().map(|t| ms(t as i64 - start)),
            sent_late_ms: self
                .note_lateness_us
                .as_ref()
                .and_then(|l| l.get(i).copied().flatten())
                .map(|us| ms(i64::from(us))),
            sounded_ms: onset_us.map(|e| ms(r.score_at_us + e - start)),
            onset_ms: onset_us.map(ms),
            sounded_velocity: onset_us.and(r.sounded_velocity),
        }
    }
}
