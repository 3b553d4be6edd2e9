//! From the LED's path to beats: the ictus and the tempo.
//!
//! ## The ictus
//! Image y grows downwards. The detector keeps the highest point of the path since the last
//! beat (`top`, least y) and the lowest point after it (`bottom`, greatest y). A beat is the
//! bottom once
//! - the stroke from top to bottom is at least [`BeatParams::min_stroke_px`] (a wobble, sensor
//!   noise or a baton held still makes no beat),
//! - at least two samples follow the bottom and the last is at least [`BeatParams::rise_px`]
//!   above it (the baton has turned up: the rebound), or one sample does that has risen half
//!   the stroke already (the frames between were lost), and
//! - it is at least [`BeatParams::min_interval_ms`] after the previous beat.
//!
//! It is reported two frames after the bottom sample (the earliest a turn can be told from
//! noise with a fit on both sides), with the time of the ictus itself refined below the frame:
//! a conductor's ictus is a sharp turn, a **V** in y(t), so a line is fitted to the samples on
//! each side of the bottom (the bottom sample tried on either side, two or three samples a
//! side, least squares) and the two lines are intersected; the split whose intersection lies
//! in its own gap and whose fit is best wins. If neither does (a rounded bottom), a parabola
//! through the lowest sample and its neighbours gives the vertex. Samples may be unevenly
//! spaced (dropped frames): only their times are used. The position reported is the vertex's
//! y and x interpolated at its time.
//!
//! ## The tempo
//! The last [`BeatParams::window`] beats give their intervals. The reference is the period
//! estimated at the previous beat (the median of the last three intervals before there is
//! one, or when none of them agrees with it); an interval more than [`BeatParams::outlier`]
//! (as a fraction) away from it is an outlier and is ignored: a missed beat (twice the
//! interval), an invented one (two short ones), and the long interval of a **fermata** (the
//! baton held, then a new preparation: the held interval is ignored, the tempo before it
//! stands, and the beat after it is reported at that tempo; the phase starts again at that
//! beat). A sudden real change of tempo wins as soon as the last two intervals agree with
//! each other and not with the reference: their mean becomes the reference. The tempo at a beat is
//! 60 000 / (mean of the inlier intervals among the last [`BeatParams::average`]) and, when
//! [`BeatParams::trend`] is on and at least four inliers are there, the trend of the
//! intervals (a least-squares line through them against time) carried forward to the beat, so
//! an accelerando or a ritardando is followed without a lag of half the window; the result is
//! kept within the range of those latest intervals widened by their last step, so a sudden
//! change of tempo is not extrapolated as a trend.

use std::collections::VecDeque;

/// The beat detector's parameters; pixel figures are for 640×480.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeatParams {
    /// Least height of a downstroke, pixels. Default 20.
    pub min_stroke_px: f64,
    /// How far the baton must have risen from the bottom to confirm it, pixels. Default 2.
    pub rise_px: f64,
    /// Least time between beats, ms (400 BPM). Default 150.
    pub min_interval_ms: f64,
    /// Beats kept for the tempo. Default 8.
    pub window: usize,
    /// Inlier intervals averaged for the tempo (the latest ones). Default 4.
    pub average: usize,
    /// An interval further than this fraction from the reference is an outlier. Default
    /// 0.12: a player's beat-to-beat wobble (a few %) and an accelerando's step (2–3 % a
    /// beat) stay in; a missed beat (+100 %), an invented one (−50 %), a fermata and a sudden
    /// change of tempo (until it is confirmed) stay out.
    pub outlier: f64,
    /// Follow a changing tempo by the intervals' trend. Default on.
    pub trend: bool,
}

impl Default for BeatParams {
    fn default() -> Self {
        Self {
            min_stroke_px: 20.0,
            rise_px: 2.0,
            min_interval_ms: 150.0,
            window: 8,
            average: 4,
            outlier: 0.12,
            trend: true,
        }
    }
}

/// One beat: the ictus found on the baton's path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beat {
    /// Time of the ictus, ms on the frames' clock (video time), refined below the frame.
    pub t_ms: f64,
    /// The tempo estimate at this beat, beats per minute; `None` at the first beat (no
    /// interval yet) and after a track was lost until the next beat.
    pub bpm: Option<f64>,
    /// The LED's position at the ictus, pixels.
    pub x: f64,
    /// See `x`.
    pub y: f64,
}

#[derive(Clone, Copy, Debug)]
struct Sample {
    t: f64,
    x: f64,
    y: f64,
}

/// Finds beats in the LED's path and estimates the tempo.
#[derive(Clone, Debug, Default)]
pub struct BeatDetector {
    params: BeatParams,
    samples: Vec<Sample>,
    top: Option<f64>,
    bottom: Option<usize>,
    beats: VecDeque<f64>,
    period: Option<f64>,
}

impl BeatDetector {
    /// A detector with these parameters.
    pub fn new(params: BeatParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// The parameters.
    pub fn params(&self) -> &BeatParams {
        &self.params
    }

    /// Forgets the stroke under way (the track was lost or changed); the tempo history stays.
    pub fn reset_stroke(&mut self) {
        self.samples.clear();
        self.top = None;
        self.bottom = None;
    }

    /// The LED at (x, y) at `t_ms` (times increasing). A beat when one is confirmed.
    pub fn push(&mut self, t_ms: f64, x: f64, y: f64) -> Option<Beat> {
        let s = Sample { t: t_ms, x, y };
        self.samples.push(s);
        let k = self.samples.len() - 1;
        let mut beat = None;
        if let (Some(top), Some(b)) = (self.top, self.bottom) {
            let bottom = self.samples[b];
            let stroke = bottom.y - top;
            let risen = bottom.y - y;
            // Two samples after the bottom, or one that has risen half the stroke already
            // (the frames in between were lost).
            if k > b
                && stroke >= self.params.min_stroke_px
                && risen >= self.params.rise_px
                && (k >= b + 2 || risen >= 0.5 * stroke)
            {
                let (t, vy) = self.refine(b);
                let x = self.x_at(t);
                let late_enough = self
                    .beats
                    .back()
                    .is_none_or(|&last| t - last >= self.params.min_interval_ms);
                if late_enough {
                    self.beats.push_back(t);
                    while self.beats.len() > self.params.window {
                        self.beats.pop_front();
                    }
                    self.period = self.estimate().or(self.period);
                    beat = Some(Beat {
                        t_ms: t,
                        bpm: self.bpm(),
                        x,
                        y: vy,
                    });
                }
                // The rebound is under way: the next stroke's top starts here.
                self.top = Some(y);
                self.bottom = Some(k);
            }
        }
        if beat.is_none() {
            match (self.top, self.bottom) {
                (Some(top), Some(b)) => {
                    if y < top {
                        self.top = Some(y);
                        self.bottom = Some(k);
                    } else if y >= self.samples[b].y {
                        self.bottom = Some(k);
                    }
                }
                _ => {
                    self.top = Some(y);
                    self.bottom = Some(k);
                }
            }
        }
        // Keep what a fit can need: the samples from two before the bottom on.
        let keep_from = self.bottom.unwrap_or(k).saturating_sub(3);
        if keep_from > 64 {
            self.samples.drain(..keep_from);
            self.bottom = self.bottom.map(|b| b - keep_from);
        }
        beat
    }

    fn x_at(&self, t: f64) -> f64 {
        let s = &self.samples;
        for w in s.windows(2) {
            if w[0].t <= t && t <= w[1].t {
                let f = if w[1].t > w[0].t {
                    (t - w[0].t) / (w[1].t - w[0].t)
                } else {
                    0.0
                };
                return w[0].x + f * (w[1].x - w[0].x);
            }
        }
        s.iter()
            .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
            .map_or(0.0, |s| s.x)
    }

    /// The ictus near sample `b`: (time, y).
    fn refine(&self, b: usize) -> (f64, f64) {
        let s = &self.samples;
        let fit = |idx: &[usize]| -> Option<(f64, f64, f64)> {
            // y = a + m t, least squares; (a, m, sse).
            let n = idx.len() as f64;
            let t0 = s[b].t;
            let mt = idx.iter().map(|&i| s[i].t - t0).sum::<f64>() / n;
            let my = idx.iter().map(|&i| s[i].y).sum::<f64>() / n;
            let stt: f64 = idx.iter().map(|&i| (s[i].t - t0 - mt).powi(2)).sum();
            if stt <= 1e-9 {
                return None;
            }
            let sty: f64 = idx
                .iter()
                .map(|&i| (s[i].t - t0 - mt) * (s[i].y - my))
                .sum();
            let m = sty / stt;
            let a = my - m * mt;
            let sse = idx
                .iter()
                .map(|&i| (s[i].y - a - m * (s[i].t - t0)).powi(2))
                .sum();
            Some((a, m, sse))
        };
        let mut best: Option<(f64, f64, f64)> = None;
        let lo = b.saturating_sub(2);
        let hi = (b + 2).min(s.len() - 1);
        if b >= 2 {
            for bottom_left in [true, false] {
                let (left, right): (Vec<usize>, Vec<usize>) = if bottom_left {
                    ((lo..=b).collect(), (b + 1..=hi).collect())
                } else {
                    ((lo..b).collect(), (b..=hi).collect())
                };
                if left.len() < 2 || right.len() < 2 {
                    continue;
                }
                let (Some((a1, m1, e1)), Some((a2, m2, e2))) = (fit(&left), fit(&right)) else {
                    continue;
                };
                // Down on the left (y growing), up on the right.
                if m1 <= 0.0 || m2 >= 0.0 {
                    continue;
                }
                let tr = (a2 - a1) / (m1 - m2);
                let t = s[b].t + tr;
                let (g0, g1) = if bottom_left {
                    (s[b].t, s[b + 1].t)
                } else {
                    (s[b - 1].t, s[b].t)
                };
                if t < g0 - 1e-9 || t > g1 + 1e-9 {
                    continue;
                }
                let y = a1 + m1 * tr;
                if best.is_none_or(|(_, _, e)| e1 + e2 < e) {
                    best = Some((t, y, e1 + e2));
                }
            }
        }
        if let Some((t, y, _)) = best {
            return (t, y);
        }
        // A parabola through the bottom and its neighbours.
        if b >= 1 && b + 1 < s.len() {
            let (p, q, r) = (s[b - 1], s[b], s[b + 1]);
            let (t1, t2) = (p.t - q.t, r.t - q.t);
            let (d1, d2) = (p.y - q.y, r.y - q.y);
            // y - yq = A t² + B t through (t1, d1), (t2, d2).
            let den = t1 * t2 * (t1 - t2);
            if den.abs() > 1e-12 {
                let a = (d1 * t2 - d2 * t1) / den;
                let bb = (d2 * t1 * t1 - d1 * t2 * t2) / den;
                if a < 0.0 {
                    let tv = (-bb / (2.0 * a)).clamp(t1, t2);
                    return (q.t + tv, q.y + a * tv * tv + bb * tv);
                }
            }
        }
        (s[b].t, s[b].y)
    }

    /// The tempo now, BPM (as estimated at the last beat; see the [module notes](self)).
    pub fn bpm(&self) -> Option<f64> {
        self.period.map(|p| 60_000.0 / p)
    }

    /// The period estimated from the beats so far, ms.
    fn estimate(&self) -> Option<f64> {
        let times: Vec<f64> = self.beats.iter().copied().collect();
        if times.len() < 2 {
            return None;
        }
        let intervals: Vec<(f64, f64)> = times
            .windows(2)
            .map(|w| ((w[0] + w[1]) / 2.0, w[1] - w[0]))
            .collect();
        let band = self.params.outlier;
        let agree = |a: f64, b: f64| (a / b - 1.0).abs() <= band;
        let recent: Vec<f64> = intervals.iter().rev().take(3).map(|i| i.1).collect();
        let reference = match self.period {
            Some(p) => {
                let last_two_moved = recent.len() >= 2
                    && agree(recent[0], recent[1])
                    && !agree(recent[0], p)
                    && !agree(recent[1], p);
                if last_two_moved {
                    (recent[0] + recent[1]) / 2.0
                } else if recent.iter().any(|&r| agree(r, p)) {
                    p
                } else {
                    median(&recent)
                }
            }
            None => median(&recent),
        };
        let inliers: Vec<(f64, f64)> = intervals
            .iter()
            .copied()
            .filter(|&(_, d)| agree(d, reference))
            .collect();
        if inliers.is_empty() {
            return None;
        }
        let now = *times.last()?;
        let last: Vec<(f64, f64)> = inliers
            .iter()
            .rev()
            .take(self.params.average.max(1))
            .copied()
            .collect();
        let mean = last.iter().map(|i| i.1).sum::<f64>() / last.len() as f64;
        let mut period = mean;
        if self.params.trend && inliers.len() >= 4 {
            let n = inliers.len() as f64;
            let mt = inliers.iter().map(|i| i.0).sum::<f64>() / n;
            let md = inliers.iter().map(|i| i.1).sum::<f64>() / n;
            let stt: f64 = inliers.iter().map(|i| (i.0 - mt).powi(2)).sum();
            let std: f64 = inliers.iter().map(|i| (i.0 - mt) * (i.1 - md)).sum();
            if stt > 0.0 {
                let slope = std / stt;
                // Never past the latest intervals by more than their last step: a sudden
                // change of tempo is not a trend to extrapolate.
                let lo = last.iter().map(|i| i.1).fold(f64::INFINITY, f64::min);
                let hi = last.iter().map(|i| i.1).fold(0.0, f64::max);
                let step = if last.len() >= 2 {
                    (last[0].1 - last[1].1).abs()
                } else {
                    0.0
                };
                period = (md + slope * (now - mt)).clamp(lo - step, hi + step);
            }
        }
        (period > 0.0).then_some(period)
    }

    /// When the next beat is due at the present tempo, ms: the phase. `None` before two beats.
    pub fn next_beat_ms(&self) -> Option<f64> {
        Some(self.beats.back()? + 60_000.0 / self.bpm()?)
    }
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}
