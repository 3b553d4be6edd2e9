//! A key's amplitude envelope, for timing its onsets: each partial's band demodulated to an
//! analytic signal by a zero-phase filter, its magnitude summed over the partials.
//!
//! A short-time spectrum's power rises with a ripple that depends on each partial's phase
//! at the onset (the truncated negative-frequency image leaks into the positive bins), worst
//! in the bass, where it moves a half-way crossing by several ms. The analytic signal's
//! magnitude has no such ripple, and a symmetric (zero-phase) band filter turns a step into a
//! rise that crosses half its height exactly at the step, whatever its loudness.
//!
//! The band of partial `h` is centred on `h f0`, half-width `B = min(0.45 f0, 80 Hz)` (at
//! least 1.2 % of the partial's frequency, for inharmonicity), Hann-shaped (so the filter's
//! kernel is smooth and short: about ±1/B); partials below 8 kHz, at most 16. The segment
//! is 2^k samples (about 0.74 s at 44.1 kHz) from 250 ms before the expected onset; each
//! band is moved to baseband and inverse-transformed at 1/64 of the rate, so the envelope
//! has a point every 64 samples (1.45 ms at 44.1 kHz), interpolated linearly.

use std::sync::Arc;

use realfft::num_complex::Complex;
use realfft::{RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};

/// The envelope's decimation.
pub(crate) const DECIMATE: usize = 64;

/// The demodulator of one key.
pub(crate) struct Demod {
    fft: Arc<dyn RealToComplex<f32>>,
    ifft: Arc<dyn Fft<f32>>,
    input: Vec<f32>,
    spectrum: Vec<Complex<f32>>,
    /// (first bin, gains) of each partial's band.
    bands: Vec<(usize, Vec<f32>)>,
    /// Samples a point of the envelope.
    pub step: usize,
    /// The segment's length, samples.
    pub len: usize,
}

impl Demod {
    /// For MIDI note `note` at `rate`.
    pub(crate) fn new(note: u8, rate: u32) -> Self {
        let rate_f = f64::from(rate);
        let len = ((0.74 * rate_f) as usize).next_power_of_two();
        let f0 = 440.0 * 2f64.powf((f64::from(note) - 69.0) / 12.0);
        let bin = rate_f / len as f64;
        let top = 8000.0f64.min(0.45 * rate_f);
        let mut bands = Vec::new();
        for h in 1..=16u32 {
            let fc = f0 * f64::from(h);
            if fc > top {
                break;
            }
            let half = (0.45 * f0).min(80.0).max(0.012 * fc);
            let first = ((fc - half) / bin).ceil().max(1.0) as usize;
            let last = ((fc + half) / bin).floor() as usize;
            let gains = (first..=last)
                .map(|k| {
                    let x = (k as f64 * bin - fc) / half;
                    (std::f64::consts::FRAC_PI_2 * x).cos().powi(2) as f32
                })
                .collect();
            bands.push((first, gains));
        }
        let m = len / DECIMATE;
        let fft = RealFftPlanner::<f32>::new().plan_fft_forward(len);
        let ifft = FftPlanner::<f32>::new().plan_fft_inverse(m);
        Self {
            input: fft.make_input_vec(),
            spectrum: fft.make_output_vec(),
            fft,
            ifft,
            bands,
            step: DECIMATE,
            len,
        }
    }

    /// The envelope of `x` from sample `start` on: one point every [`step`](Self::step)
    /// samples, `len / step` points (samples outside `x` are 0).
    pub(crate) fn envelope(&mut self, x: &[f32], start: i64) -> Vec<f64> {
        for (i, v) in self.input.iter_mut().enumerate() {
            let j = start + i as i64;
            *v = if j >= 0 && (j as usize) < x.len() {
                x[j as usize]
            } else {
                0.0
            };
        }
        self.fft
            .process(&mut self.input, &mut self.spectrum)
            .expect("buffers are the planner's own");
        let m = self.len / DECIMATE;
        let mut sum = vec![0.0f64; m];
        let mut buf = vec![Complex::new(0.0f32, 0.0); m];
        for (first, gains) in &self.bands {
            buf.iter_mut().for_each(|c| *c = Complex::new(0.0, 0.0));
            // The band's centre at baseband (bin 0), the rest around it, wrapped.
            let centre = first + gains.len() / 2;
            for (i, g) in gains.iter().enumerate() {
                let k = first + i;
                let at = (k as i64 - centre as i64).rem_euclid(m as i64) as usize;
                buf[at] = self.spectrum[k] * *g;
            }
            self.ifft.process(&mut buf);
            for (s, c) in sum.iter_mut().zip(&buf) {
                *s += f64::from(c.norm());
            }
        }
        sum
    }
}
