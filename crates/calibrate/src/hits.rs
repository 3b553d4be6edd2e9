//! Listening for a strike output's hits: a drum has no partials to listen on, so its onset
//! is found and timed on the recording's broadband energy.
//!
//! - **Energy**: the mean square of the recording over a centred [`WINDOW_MS`] window, at
//!   every sample (from a running sum): short enough to time an abrupt hit within a fraction
//!   of a ms, long enough (88 samples at 44.1 kHz) that the noise's energy scatters by
//!   about 15 %.
//! - **Noise**: that energy at 31 points, 10 ms apart, from 450 to 150 ms before each
//!   expected hit (the room, the previous drum's or cymbal's tail): its median and robust
//!   standard deviation (1.4826 × MAD).
//! - **A hit**: from 100 ms before the expected onset to 250 ms after it, the first point
//!   where the energy exceeds the noise's median by [`LAMBDA`] robust standard deviations
//!   and by half again its median; its peak is the largest energy in the 20 ms after. A hit
//!   whose peak is not [`PEAK_OVER_NOISE`] times the noise's median is silence.
//! - **Timing**: from the detection back to where the energy was last at its level before
//!   (the larger of the noise's median and the median of the 40 to 10 ms before the
//!   detection) plus [`LOW_LAMBDA`] robust standard deviations of the noise (at least 30 %
//!   of it): the start of the rise, whatever its shape (a kick's low body starting from a
//!   zero crossing takes a quarter of its period, 4 ms, to its first peak; a share of the way
//!   to the peak came that much late). Walking back from the detection, a noise spike before
//!   the hit cannot take it. A step at `t0` of energy `P` over the level before `B` crosses
//!   `L` at `t0 − w/2 + w (L − B) / (P − B)` for a window `w` long, so the onset is the
//!   crossing plus `w (1/2 − (L − B) / (P − B))`, `P` the peak. It is the hit's audible
//!   onset, as a key's is: a drum sample with a slow attack is timed where it rises.
//! - **Level**: the mean energy over the [`LEVEL_MS`] from the onset, less the noise's
//!   median, in dB (0 dB: a full-scale square wave's power); the same span at every level
//!   of an output.
//!
//! Only the first rise counts: a drum's ring, a cymbal's swell or a room's echo after it is
//! not a second hit (a beater bouncing back onto the head is not detected).

use crate::onset::{median, robust_sigma};

/// The energy's window, ms.
pub(crate) const WINDOW_MS: f64 = 2.0;
/// Robust standard deviations above the noise's median a hit's energy must rise.
const LAMBDA: f64 = 8.0;
/// A hit's peak energy must be this many times the noise's median (5 dB).
const PEAK_OVER_NOISE: f64 = 3.0;
/// The level's span from the onset, ms: a closed hi-hat has died 20 dB by then.
pub(crate) const LEVEL_MS: f64 = 30.0;
/// The listening window before and after the expected onset, ms.
pub(crate) const BEFORE_MS: f64 = 100.0;
pub(crate) const AFTER_MS: f64 = 250.0;
/// Robust standard deviations of the noise over its level at which the rise is timed ...
const LOW_LAMBDA: f64 = 3.0;
/// ... or this share of the way to the peak, if higher.
const PEAK_SHARE: f64 = 0.05;

/// What was heard of one hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Hit {
    /// Its onset, ms in the recording.
    pub onset_ms: f64,
    /// Its level, dB.
    pub level_db: f64,
    /// How far the noise may move that level, dB.
    pub level_sigma_db: f64,
    /// How far its peak energy stood over the level before it, dB.
    pub over_db: f64,
}

/// The recording's energy at any sample, from a running sum of its squares.
pub(crate) struct Energy {
    sums: Vec<f64>,
    rate: f64,
    half: usize,
}

impl Energy {
    /// Of `x` at `rate` Hz.
    pub(crate) fn new(x: &[f32], rate: u32) -> Self {
        let mut sums = Vec::with_capacity(x.len() + 1);
        let mut acc = 0.0f64;
        sums.push(0.0);
        for &v in x {
            acc += f64::from(v) * f64::from(v);
            sums.push(acc);
        }
        let rate = f64::from(rate);
        let half = ((WINDOW_MS / 2000.0 * rate).round() as usize).max(1);
        Self { sums, rate, half }
    }

    /// The mean square over `[from, to)` samples (clamped to the recording).
    fn mean(&self, from: i64, to: i64) -> f64 {
        let n = self.sums.len() as i64 - 1;
        let (a, b) = (from.clamp(0, n) as usize, to.clamp(0, n) as usize);
        if b <= a {
            return 0.0;
        }
        (self.sums[b] - self.sums[a]) / (b - a) as f64
    }

    /// The energy over the window centred on sample `n`.
    fn at(&self, n: i64) -> f64 {
        self.mean(n - self.half as i64, n + self.half as i64)
    }

    fn sample(&self, ms: f64) -> i64 {
        (ms / 1000.0 * self.rate).round() as i64
    }

    fn ms(&self, n: f64) -> f64 {
        n * 1000.0 / self.rate
    }

    /// Listens for the hit expected at `expected_ms`: `None` if none rose from the noise.
    pub(crate) fn hit(&self, expected_ms: f64) -> Option<Hit> {
        let mut noise: Vec<f64> = (0..=30)
            .map(|i| self.at(self.sample(expected_ms - 450.0 + 10.0 * f64::from(i))))
            .collect();
        let sigma = robust_sigma(&noise);
        let floor = median(&mut noise);
        let threshold = (floor + LAMBDA * sigma).max(1.5 * floor);
        let (from, to) = (
            self.sample(expected_ms - BEFORE_MS),
            self.sample(expected_ms + AFTER_MS),
        );
        // The first rise over the threshold whose peak stands over the noise (a noise
        // excursion over the threshold alone is passed over).
        let ms20 = self.sample(20.0);
        let mut start = from;
        let (found, peak) = loop {
            let found = (start..to).find(|&n| self.at(n) > threshold)?;
            let peak = (found..found + ms20)
                .map(|n| self.at(n))
                .fold(0.0, f64::max);
            if peak >= PEAK_OVER_NOISE * floor.max(1e-20) {
                break (found, peak);
            }
            start = found + ms20;
        };
        let mut before: Vec<f64> = (found - self.sample(40.0)..found - self.sample(10.0))
            .step_by(self.half.max(1))
            .map(|n| self.at(n))
            .collect();
        let base = median(&mut before).max(floor);
        // The noise's scatter, in proportion where a tail raised the level before.
        let low = base
            + (LOW_LAMBDA * sigma * base / floor.max(1e-20))
                .max(0.3 * base)
                .max(PEAK_SHARE * (peak - base));
        let mut n = found;
        while n > from && self.at(n - 1) > low {
            n -= 1;
        }
        // Between n − 1 (at or below) and n (above): interpolated.
        let (e0, e1) = (self.at(n - 1), self.at(n));
        let frac = if e1 > e0 { (low - e0) / (e1 - e0) } else { 1.0 };
        let crossing = (n - 1) as f64 + frac.clamp(0.0, 1.0);
        let w = 2.0 * self.half as f64;
        let share = ((low - base) / (peak - base)).clamp(0.0, 0.5);
        let onset = crossing + (0.5 - share) * w;
        let span = self.sample(LEVEL_MS);
        let start = onset.round() as i64;
        let mean = (self.mean(start, start + span) - floor).max(1e-20);
        Some(Hit {
            onset_ms: self.ms(onset),
            level_db: 10.0 * mean.log10() + 3.0103,
            level_sigma_db: crate::listen::level_sigma_db(mean, sigma, WINDOW_MS, LEVEL_MS),
            over_db: 10.0 * (peak / base).log10(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Rng;

    /// A decaying noise burst from `at_ms`, over noise `noise` (RMS), 44.1 kHz, 1 s.
    fn burst(at_ms: f64, amp: f64, noise: f64, seed: u64) -> Vec<f32> {
        let mut rng = Rng::new(seed);
        (0..44_100)
            .map(|n| {
                let t = (n as f64 / 44.1 - at_ms) / 1000.0;
                let hit = if t >= 0.0 {
                    amp * (-t / 0.05).exp() * rng.normal()
                } else {
                    0.0
                };
                (hit + noise * rng.normal()) as f32
            })
            .collect()
    }

    #[test]
    fn an_abrupt_hit_is_timed_within_a_few_tenths_of_a_ms() {
        for (seed, at) in [(1, 600.0), (2, 612.37), (3, 633.9)] {
            let x = burst(at, 0.3, 0.003, seed);
            let h = Energy::new(&x, 44_100).hit(620.0).unwrap();
            assert!((h.onset_ms - at).abs() < 0.3, "{at}: {h:?}");
        }
    }

    #[test]
    fn a_soft_hit_is_timed_and_quieter_and_silence_is_none() {
        let loud = Energy::new(&burst(610.0, 0.3, 0.003, 4), 44_100)
            .hit(600.0)
            .unwrap();
        let soft = Energy::new(&burst(610.0, 0.03, 0.003, 4), 44_100)
            .hit(600.0)
            .unwrap();
        assert!((soft.onset_ms - 610.0).abs() < 1.0, "{soft:?}");
        assert!(
            (loud.level_db - soft.level_db - 20.0).abs() < 1.0,
            "{loud:?} {soft:?}"
        );
        assert!(Energy::new(&burst(610.0, 0.0, 0.003, 5), 44_100)
            .hit(600.0)
            .is_none());
    }
}
