//! Finding the sync figure: the recording's clock against the score's.
//!
//! Each broadband onset is tried as the figure's first strike; the figure's other strikes
//! must then have onsets at their own times (±50 ms: the figure's keys differ in press
//! delay by up to a few tens of ms), and the figure's span must hold no other onset. This is
//! the cross-correlation of the onset train with the figure's pattern, scored by hits and
//! misses (an onset under half the figure's weakest strike is a ripple of its decay or a damper,
//! not a stranger). The best shift is kept (most strikes found, then fewest strangers, then the
//! smallest timing error, then the earliest); at least 4 of its 5 strikes must be there and
//! at most one stranger, or the figure is not in the recording.

use crate::onset::Onset;
use crate::score::{LEAD_IN_MS, SYNC_MARKS_MS};

/// How far a figure strike's onset may be from its place, s.
const TOLERANCE_S: f64 = 0.050;
/// An onset in the figure's span weaker than this share of the figure's weakest strike is
/// a ripple of its decay or a damper falling, not a stranger.
const STRANGER: f64 = 0.5;
/// The fewest figure strikes that count as the figure.
pub(crate) const MIN_HITS: usize = 4;

/// Where the figure was found: the capture offset (the recording's time of the score's time
/// 0, plus the figure keys' mean press delay at full power), ms.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Found {
    pub offset_ms: f64,
}

/// The best match, or the most strikes found anywhere.
pub(crate) fn find(onsets: &[Onset]) -> Result<Found, usize> {
    let marks: Vec<f64> = SYNC_MARKS_MS
        .iter()
        .map(|&m| f64::from(m) / 1000.0)
        .collect();
    let span = marks[marks.len() - 1];
    // (hits, strangers, squared error, offset)
    let mut best: Option<(usize, usize, f64, f64)> = None;
    let mut most = 0;
    for (i, first) in onsets.iter().enumerate() {
        let t0 = first.t_s;
        let mut hits = 0;
        let mut err = 0.0;
        let mut used = Vec::new();
        let mut sum = 0.0;
        let mut weakest = f64::INFINITY;
        for &m in &marks {
            let want = t0 + m;
            let near = onsets[i..]
                .iter()
                .enumerate()
                .filter(|(_, o)| (o.t_s - want).abs() <= TOLERANCE_S)
                .min_by(|a, b| (a.1.t_s - want).abs().total_cmp(&(b.1.t_s - want).abs()));
            if let Some((j, o)) = near {
                hits += 1;
                err += (o.t_s - want).powi(2);
                used.push(i + j);
                sum += o.t_s - m;
                weakest = weakest.min(o.flux);
            }
        }
        most = most.max(hits);
        let strangers = onsets
            .iter()
            .enumerate()
            .filter(|(j, o)| {
                o.t_s > t0 - 0.1
                    && o.t_s < t0 + span + 0.1
                    && !used.contains(j)
                    && o.flux >= STRANGER * weakest
            })
            .count();
        if hits < MIN_HITS || strangers > 1 {
            continue;
        }
        let offset = sum / hits as f64;
        let better = match best {
            None => true,
            Some((h, s, e, _)) => {
                (hits, std::cmp::Reverse(strangers)) > (h, std::cmp::Reverse(s))
                    || (hits == h && strangers == s && err < e - 1e-9)
            }
        };
        if better {
            best = Some((hits, strangers, err, offset));
        }
    }
    match best {
        Some((_, _, _, offset)) => Ok(Found {
            offset_ms: offset * 1000.0 - f64::from(LEAD_IN_MS),
        }),
        None => Err(most),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(times: &[f64]) -> Vec<Onset> {
        times.iter().map(|&t| Onset { t_s: t, flux: 1.0 }).collect()
    }

    #[test]
    fn the_figure_is_found_among_evenly_spaced_strikes() {
        let mut t = vec![3.0, 3.15, 3.6, 4.35, 4.65];
        t.extend((0..20).map(|i| 7.0 + f64::from(i)));
        let f = find(&at(&t)).unwrap();
        assert!((f.offset_ms - 2000.0).abs() < 1.0, "{f:?}");
    }

    #[test]
    fn evenly_spaced_strikes_alone_are_not_the_figure() {
        let t: Vec<f64> = (0..40).map(|i| 1.0 + 0.15 * f64::from(i)).collect();
        assert!(find(&at(&t)).is_err());
        let t: Vec<f64> = (0..40).map(|i| 1.0 + f64::from(i)).collect();
        assert!(find(&at(&t)).is_err());
    }
}
