//! Short-time power spectra (Hann window, real FFT) and a key's harmonic bins.

use std::sync::Arc;

use realfft::{num_complex::Complex, RealFftPlanner, RealToComplex};

/// The power spectrum of frames of one length.
pub(crate) struct Stft {
    fft: Arc<dyn RealToComplex<f32>>,
    window: Vec<f32>,
    input: Vec<f32>,
    output: Vec<Complex<f32>>,
    scratch: Vec<Complex<f32>>,
    /// Scales |X_k|² into mean-square power of the signal (one-sided, Hann-corrected).
    norm: f32,
}

impl Stft {
    /// Frames of `n` samples (even).
    pub(crate) fn new(n: usize) -> Self {
        let fft = RealFftPlanner::<f32>::new().plan_fft_forward(n);
        let window: Vec<f32> = (0..n)
            .map(|i| {
                let x = std::f32::consts::PI * 2.0 * i as f32 / n as f32;
                0.5 - 0.5 * x.cos()
            })
            .collect();
        let w2: f32 = window.iter().map(|w| w * w).sum();
        Self {
            input: fft.make_input_vec(),
            output: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
            fft,
            window,
            norm: 2.0 / (n as f32 * w2),
        }
    }

    /// The power in each bin (mean-square units) of the frame centred on sample `centre`;
    /// samples outside the signal are 0.
    pub(crate) fn power(&mut self, x: &[f32], centre: i64, out: &mut Vec<f32>) {
        let n = self.window.len() as i64;
        let start = centre - n / 2;
        for (i, v) in self.input.iter_mut().enumerate() {
            let j = start + i as i64;
            *v = if j >= 0 && (j as usize) < x.len() {
                x[j as usize] * self.window[i]
            } else {
                0.0
            };
        }
        self.fft
            .process_with_scratch(&mut self.input, &mut self.output, &mut self.scratch)
            .expect("buffers are the planner's own");
        out.clear();
        out.extend(self.output.iter().map(|c| c.norm_sqr() * self.norm));
    }
}

/// A key's bins: around each partial, and one between each two partials.
#[derive(Clone, Debug)]
pub(crate) struct KeyBand {
    /// The frame length for this key.
    pub n: usize,
    /// Bins at and next to the key's partials.
    pub harmonic: Vec<usize>,
    /// Bins half-way between partials: what the room puts there (noise, a click, another
    /// key) and the string does not.
    pub between: Vec<usize>,
}

/// The highest partial frequency looked at: above it a string has little energy left and a
/// room's noise and clicks have plenty.
const TOP_HZ: f64 = 8000.0;
/// The most partials looked at (those below 8 kHz).
const PARTIALS: u32 = 16;

impl KeyBand {
    /// The bins of MIDI note `note` at `rate`. The frame is long enough to put 4 bins
    /// between partials (at least 1024 samples, at most 8192): 93 ms for C2 at 44.1 kHz,
    /// 23 ms from about G3 up.
    pub(crate) fn new(note: u8, rate: u32) -> Self {
        let f0 = 440.0 * 2f64.powf((f64::from(note) - 69.0) / 12.0);
        let n = ((4.0 * f64::from(rate) / f0).ceil() as usize)
            .next_power_of_two()
            .clamp(1024, 8192);
        Self::with_len(note, rate, n, 0.0)
    }

    /// The bins of MIDI note `note` at `rate` in frames of `n` samples, partials from
    /// `min_hz` up.
    pub(crate) fn with_len(note: u8, rate: u32, n: usize, min_hz: f64) -> Self {
        let f0 = 440.0 * 2f64.powf((f64::from(note) - 69.0) / 12.0);
        let rate_f = f64::from(rate);
        let bin = rate_f / n as f64;
        let top = TOP_HZ.min(0.45 * rate_f);
        let bins = n / 2 + 1;
        let mut harmonic = Vec::new();
        let mut between = Vec::new();
        for h in 1..=PARTIALS {
            let f = f0 * f64::from(h);
            if f > top {
                break;
            }
            if f < min_hz {
                continue;
            }
            // A piano's partials run sharp (inharmonicity): up to about 1 % at the 12th.
            let lo = ((f * 0.995 / bin).round() as usize).saturating_sub(1);
            let hi = ((f * 1.01 / bin).round() as usize + 1).min(bins - 1);
            harmonic.extend(lo.max(1)..=hi);
            let mid = (f + 0.5 * f0) / bin;
            if mid * bin < top {
                between.push(mid.round() as usize);
            }
        }
        harmonic.sort_unstable();
        harmonic.dedup();
        between.retain(|b| !harmonic.contains(b) && *b < bins);
        Self {
            n,
            harmonic,
            between,
        }
    }

    /// The string's power in a spectrum: the harmonic bins' power less what the between bins
    /// say the room puts in as many bins (so broadband noise and clicks count about 0).
    pub(crate) fn string_power(&self, p: &[f32]) -> f64 {
        let h: f64 = self.harmonic.iter().map(|&b| f64::from(p[b])).sum();
        if self.between.is_empty() {
            return h;
        }
        let mean: f64 =
            self.between.iter().map(|&b| f64::from(p[b])).sum::<f64>() / self.between.len() as f64;
        h - mean * self.harmonic.len() as f64
    }

    /// The mean magnitude of the harmonic bins (for the flux's compression).
    pub(crate) fn harmonic_magnitudes<'a>(
        &'a self,
        p: &'a [f32],
    ) -> impl Iterator<Item = f32> + 'a {
        self.harmonic.iter().map(move |&b| p[b].sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sine_has_its_mean_square_power() {
        let rate = 44_100;
        let x: Vec<f32> = (0..8192)
            .map(|i| 0.5 * (2.0 * std::f32::consts::PI * 1000.0 * i as f32 / rate as f32).sin())
            .collect();
        let mut s = Stft::new(2048);
        let mut p = Vec::new();
        s.power(&x, 4096, &mut p);
        let total: f32 = p.iter().sum();
        assert!((total - 0.125).abs() < 0.01, "{total}");
    }

    #[test]
    fn key_bands_keep_between_bins_apart_from_partials() {
        for note in [36, 60, 96] {
            let b = KeyBand::new(note, 44_100);
            assert!(!b.harmonic.is_empty());
            assert!(!b.between.is_empty() || note == 96, "{note}: {b:?}");
            assert!(b.between.iter().all(|x| !b.harmonic.contains(x)));
        }
        assert_eq!(KeyBand::new(36, 44_100).n, 4096);
        assert_eq!(KeyBand::new(72, 44_100).n, 1024);
    }
}
