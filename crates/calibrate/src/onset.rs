//! Broadband onsets, for finding the sync figure: spectral flux on log-compressed
//! magnitudes, half-wave rectified, with an adaptive threshold and peak picking (Dixon 2006,
//! "Onset detection revisited", its SF method).
//!
//! Parameters: a Hann frame of about 46 ms (2048 samples at 44.1 kHz), a hop of 10 ms,
//! bins from 30 Hz to 8 kHz, magnitudes compressed as ln(1 + γ|X|) with γ the inverse of the
//! recording's median frame magnitude (so the noise floor sits near ln 2 whatever the gain),
//! the flux the mean rectified rise from the frame before. A frame is an onset when its flux
//! is the largest within ±50 ms and exceeds the median flux of the surrounding ±0.5 s plus 8
//! robust standard deviations (1.4826 × the median absolute deviation) of the whole
//! recording's flux: the noise floor sets the threshold, and a loud passage raises it
//! locally. In a quiet room, at least 5 % of the recording's largest flux.

use crate::spectrum::Stft;
use crate::wav::Recording;

/// The hop, s.
pub(crate) const HOP_S: f64 = 0.010;
/// How many robust standard deviations above the local median an onset's flux must be.
const LAMBDA: f64 = 8.0;
/// The local median's half-width, frames (0.5 s).
const LOCAL: usize = 50;
/// Peaks closer than this (frames, 50 ms) are one onset.
const NEIGHBOURHOOD: usize = 5;

/// One onset found: its time (the frame's centre, s) and flux.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Onset {
    pub t_s: f64,
    pub flux: f64,
}

/// The recording's broadband onsets, in time order.
pub(crate) fn broadband(rec: &Recording) -> Vec<Onset> {
    let rate = f64::from(rec.rate);
    let n = ((rate * 0.046) as usize).next_power_of_two();
    let hop = (rate * HOP_S).round() as usize;
    let lo = ((30.0 / rate * n as f64).ceil() as usize).max(1);
    let hi = ((8000.0f64.min(rate * 0.45) / rate * n as f64) as usize).min(n / 2);
    let frames = rec.samples.len() / hop + 1;
    let mut stft = Stft::new(n);
    let mut p = Vec::new();
    let mut mags: Vec<Vec<f32>> = Vec::with_capacity(frames);
    let mut frame_means = Vec::with_capacity(frames);
    for f in 0..frames {
        stft.power(&rec.samples, (f * hop) as i64, &mut p);
        let m: Vec<f32> = p[lo..hi].iter().map(|x| x.sqrt()).collect();
        frame_means.push(f64::from(m.iter().sum::<f32>()) / m.len() as f64);
        mags.push(m);
    }
    let gamma = 1.0 / median(&mut frame_means.clone()).max(1e-12);
    let mut flux = vec![0.0f64; frames];
    let mut prev: Vec<f64> = Vec::new();
    for (f, m) in mags.iter().enumerate() {
        let cur: Vec<f64> = m
            .iter()
            .map(|&x| (1.0 + gamma * f64::from(x)).ln())
            .collect();
        if f > 0 {
            flux[f] = cur
                .iter()
                .zip(&prev)
                .map(|(c, q)| (c - q).max(0.0))
                .sum::<f64>()
                / cur.len() as f64;
        }
        prev = cur;
    }
    let sigma = robust_sigma(&flux);
    // In a quiet room the noise's flux is tiny; a ripple in a decay must not count.
    let floor = 0.05 * flux.iter().copied().fold(0.0, f64::max);
    let mut out = Vec::new();
    let mut window = Vec::with_capacity(2 * LOCAL + 1);
    for f in 1..frames {
        let a = f.saturating_sub(NEIGHBOURHOOD);
        let b = (f + NEIGHBOURHOOD + 1).min(frames);
        if flux[a..b].iter().any(|&x| x > flux[f]) {
            continue;
        }
        // The first frame of a flat top only.
        if flux[a..f].contains(&flux[f]) {
            continue;
        }
        window.clear();
        window.extend_from_slice(&flux[f.saturating_sub(LOCAL)..(f + LOCAL + 1).min(frames)]);
        let threshold = median(&mut window) + LAMBDA * sigma;
        if flux[f] > threshold.max(floor) {
            out.push(Onset {
                t_s: (f * hop) as f64 / rate,
                flux: flux[f],
            });
        }
    }
    out
}

/// The median (reorders `x`); 0 for none.
pub(crate) fn median(x: &mut [f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mid = x.len() / 2;
    let (_, m, _) = x.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// 1.4826 × the median absolute deviation: a standard deviation that outliers (the strikes
/// themselves) do not move.
pub(crate) fn robust_sigma(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    let m = median(&mut v);
    let mut d: Vec<f64> = x.iter().map(|y| (y - m).abs()).collect();
    1.4826 * median(&mut d)
}
