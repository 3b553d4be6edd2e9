//! Where things go: the scale, the rows a long piece is folded into, the pitch axis.
//!
//! Time runs left to right at a fixed [`Options::px_per_s`]; a piece longer than one row
//! ([`Options::max_row_px`]) goes on in further rows below, like the systems of a score, each
//! row holding whole bars (a bar longer than a row is cut where the row ends). Pitch runs
//! bottom to top, one [`Options::semitone_px`] a semitone, over the same notes in every row:
//! the robot's keys and every note written or landed, one semitone of room either side.

use crate::model::{Roll, RollNote};

/// The scale of the drawing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Pixels a second of performance time (80: a sixteenth note at 120 bpm is 10 px, and a
    /// note 10 ms late is 0.8 px off, so lateness is shown by colour, not only by position).
    pub px_per_s: f64,
    /// The longest row, px of time (1600: 20 s a row at 80 px/s); the drawing is at most this
    /// plus the pitch axis wide, however long the piece.
    pub max_row_px: f64,
    /// Pixels a semitone (6: the 61 keys and a little room take about 380 px a row).
    pub semitone_px: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            px_per_s: 80.0,
            max_row_px: 1600.0,
            semitone_px: 6.0,
        }
    }
}

/// Left of the time axis: the note names.
pub const LEFT: f64 = 44.0;
/// Right of the last row's end.
pub const RIGHT: f64 = 12.0;
/// Above each row's pitch area: the bar numbers.
pub const ROW_HEAD: f64 = 16.0;
/// Below each row.
pub const ROW_GAP: f64 = 14.0;
/// A named lane's height, in semitones' heights.
pub const LANE_SEMITONES: f64 = 2.0;

/// One row: a stretch of time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Where it begins and ends, ms.
    pub from_ms: f64,
    pub to_ms: f64,
    /// The top of its pitch area, px.
    pub top: f64,
}

/// The drawing's geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub rows: Vec<Row>,
    /// The lowest and highest note of the pitch axis.
    pub lo: u8,
    pub hi: u8,
    pub px_per_ms: f64,
    pub semitone: f64,
    /// Whether a row has pitch rows (see [`Roll::pitched`]).
    pub pitched: bool,
    /// The named lanes below the pitch rows, and each one's height, px.
    pub lanes: usize,
    pub lane_px: f64,
    /// Left of the time axis: the note names, or the lanes' names if longer.
    pub left: f64,
    pub width: f64,
    pub height: f64,
}

impl Layout {
    /// The layout of `roll` at `opts`, its first row `top` px down.
    pub fn new(roll: &Roll, opts: &Options, top: f64) -> Self {
        let px_per_ms = opts.px_per_s.max(1e-3) / 1000.0;
        let max_ms = (opts.max_row_px.max(50.0) / px_per_ms).max(1.0);
        let end = roll.end_ms.max(1000.0);
        let (lo, hi) = pitch_span(roll);
        let semitone = opts.semitone_px.max(1.0);
        let lane_px = semitone * LANE_SEMITONES;
        let pitch_h = if roll.pitched {
            f64::from(hi - lo + 1) * semitone
        } else {
            0.0
        } + roll.lanes.len() as f64 * lane_px;
        let bars: Vec<f64> = roll.bars.iter().map(|b| b.t_ms).collect();
        let mut y = top;
        let rows: Vec<Row> = split_rows(&bars, end, max_ms)
            .into_iter()
            .map(|(from_ms, to_ms)| {
                let r = Row {
                    from_ms,
                    to_ms,
                    top: y + ROW_HEAD,
                };
                y += ROW_HEAD + pitch_h + ROW_GAP;
                r
            })
            .collect();
        // A lane's name at 9 px: about 5 px a character.
        let longest = roll
            .lanes
            .iter()
            .map(|n| n.chars().count())
            .max()
            .unwrap_or(0);
        let left = LEFT.max(longest as f64 * 5.0 + 12.0);
        let widest = rows
            .iter()
            .map(|r| (r.to_ms - r.from_ms) * px_per_ms)
            .fold(0.0, f64::max);
        Self {
            rows,
            lo,
            hi,
            px_per_ms,
            semitone,
            pitched: roll.pitched,
            lanes: roll.lanes.len(),
            lane_px,
            left,
            width: left + widest + RIGHT,
            height: y,
        }
    }

    /// The height of a row's pitch rows (0 without them).
    pub fn pitch_height(&self) -> f64 {
        if self.pitched {
            f64::from(self.hi - self.lo + 1) * self.semitone
        } else {
            0.0
        }
    }

    /// The height of a row's drawing area: its pitch rows and its lanes.
    pub fn area_height(&self) -> f64 {
        self.pitch_height() + self.lanes as f64 * self.lane_px
    }

    /// The top of lane `lane` in `row`.
    pub fn lane_y(&self, row: &Row, lane: u16) -> f64 {
        row.top + self.pitch_height() + f64::from(lane) * self.lane_px
    }

    /// Where `n` is drawn in `row`, top and height: its strike's place (`strike`: the key or
    /// bar it landed on) or its written note's, or its lane for both.
    pub fn band(&self, row: &Row, n: &RollNote, strike: bool) -> (f64, f64) {
        match n.lane {
            Some(lane) => (self.lane_y(row, lane), self.lane_px),
            None if strike => (self.y(row, n.landed.unwrap_or(n.note)), self.semitone),
            None => (self.y(row, n.note), self.semitone),
        }
    }

    /// The top of `note`'s lane in `row`.
    pub fn y(&self, row: &Row, note: u8) -> f64 {
        row.top + f64::from(self.hi.saturating_sub(note)) * self.semitone
    }

    /// The x of `t_ms` in `row`.
    pub fn x(&self, row: &Row, t_ms: f64) -> f64 {
        self.left + (t_ms - row.from_ms) * self.px_per_ms
    }

    /// The parts of `from_ms..to_ms` in each row it crosses: (row, from, to).
    pub fn pieces(&self, from_ms: f64, to_ms: f64) -> Vec<(&Row, f64, f64)> {
        let first = self
            .rows
            .partition_point(|r| r.to_ms <= from_ms)
            .min(self.rows.len().saturating_sub(1));
        let mut out = Vec::new();
        for r in &self.rows[first..] {
            if r.from_ms > to_ms || (r.from_ms == to_ms && !out.is_empty()) {
                break;
            }
            out.push((r, from_ms.max(r.from_ms), to_ms.min(r.to_ms)));
        }
        out
    }
}

/// The notes of the pitch axis: the robot's keys and every note written or landed, one
/// semitone of room either side.
fn pitch_span(roll: &Roll) -> (u8, u8) {
    let (mut lo, mut hi) = roll.keys.unwrap_or((u8::MAX, 0));
    for n in roll.notes.iter().filter(|n| n.lane.is_none()) {
        for p in std::iter::once(n.note).chain(n.landed) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if lo > hi {
        return (59, 61); // nothing on pitch rows: a span that draws nothing
    }
    (lo.saturating_sub(1), hi.saturating_add(1).min(127))
}

/// `0..end_ms` cut into rows no longer than `max_ms`, each ending at a bar line where one
/// fits (`bars`: bar start times, ascending); a bar longer than a row is cut at the row's end.
pub fn split_rows(bars: &[f64], end_ms: f64, max_ms: f64) -> Vec<(f64, f64)> {
    let mut rows = Vec::new();
    let mut from = 0.0;
    let mut last_fit: Option<f64> = None;
    for &p in bars
        .iter()
        .filter(|&&b| b > 0.0 && b < end_ms)
        .chain([&end_ms])
    {
        while p - from > max_ms {
            match last_fit.take() {
                Some(l) => {
                    rows.push((from, l));
                    from = l;
                }
                None => {
                    rows.push((from, from + max_ms));
                    from += max_ms;
                }
            }
        }
        if p > from {
            last_fit = Some(p);
        }
    }
    if end_ms > from {
        rows.push((from, end_ms));
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_rows_breaks_at_bar_lines() {
        // Bars of 2 s, rows of at most 5 s: two bars a row.
        let bars = [0.0, 2000.0, 4000.0, 6000.0, 8000.0];
        assert_eq!(
            split_rows(&bars, 9500.0, 5000.0),
            [(0.0, 4000.0), (4000.0, 8000.0), (8000.0, 9500.0)]
        );
    }

    #[test]
    fn split_rows_cuts_a_bar_longer_than_a_row() {
        assert_eq!(
            split_rows(&[0.0, 12000.0], 13000.0, 5000.0),
            [(0.0, 5000.0), (5000.0, 10000.0), (10000.0, 13000.0)]
        );
    }

    #[test]
    fn split_rows_a_short_piece_is_one_row() {
        assert_eq!(split_rows(&[0.0, 500.0], 1000.0, 5000.0), [(0.0, 1000.0)]);
    }
}
