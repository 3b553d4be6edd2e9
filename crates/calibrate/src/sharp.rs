//! The sharp timing of a key's onset: the recording high-passed at the key's 4th partial,
//! where its energy rises, and where the string's periodicity starts (a solenoid's thump a
//! few ms before the string rises first and does not repeat at the key's period). The method
//! and its figures: [`crate::listen`]'s notes, "Timing, sharp" and "The string, not a thump".

use crate::onset::{median, robust_sigma};

/// The sharp timing of an onset.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sharp {
    /// The onset, ms in the recording.
    pub t: f64,
    /// Where the string's periodicity starts, ms ([`periodic_onset`]), and where the string
    /// is timed when it is ([`string_onset`]).
    pub periodic: Option<(f64, f64)>,
    /// How many times the high-passed energy rose.
    ratio: f64,
}

impl Sharp {
    /// Whether the onset is timed on it (or on the envelope and the key's offset).
    pub(crate) fn taken(self) -> bool {
        self.ratio >= SHARP_RATIO
    }
}

/// The high-passed energy must rise this many times (15 dB) for its timing to be taken.
const SHARP_RATIO: f64 = 30.0;
/// The sharp timing's high-pass: at this partial of the key ...
const SHARP_PARTIAL: f64 = 4.0;
/// ... and at least this, Hz.
const SHARP_MIN_HZ: f64 = 200.0;
/// The sharp timing's energy window, ms (centred).
const SHARP_WINDOW_MS: f64 = 3.0;
/// The sharp onset's rise must last this long, ms.
const SHARP_SUSTAIN_MS: f64 = 5.0;
/// The sharp onset: where the energy has risen this share of the way to its level after.
const SHARP_FRACTION: f64 = 0.2;
/// The sharp timing's lag is at least this long, ms: a click (or a thump's) has died
/// within it, so it does not repeat.
const PERIODIC_MIN_LAG_MS: f64 = 3.0;
/// The periodicity's rise must be this many robust standard deviations of its level before
/// (from 50 to 15 ms before the onset) to time anything: at 20 dB SNR a soft strike's
/// periodicity in noise, taken without any such bound, moved strikes without a thump up to 4
/// ms on the synthetic recordings (`--bench accuracy`). 15 since the periodicity is
/// band-limited to the key's partials ([`PERIODIC_TOP_PARTIAL`]): that lifted a soft bass
/// strike's rise from 4–10 to 15–32 of them, and at 30 it left the softest strikes of C2–B2
/// to the envelope, which a thump's thud moves up to 14 ms early.
const PERIODIC_CLEAR: f64 = 15.0;
/// The periodicity is measured below this partial of the key ... (its first 16, as the
/// key's bins): a bass key's string has nothing above, the room's noise has all the band up
/// to 22 kHz, 20 times the string's at C2 (its rise in noise 3–4 times clearer with it).
const PERIODIC_TOP_PARTIAL: f64 = 16.5;
/// ... and below this, Hz (the key's bins' top).
const PERIODIC_TOP_HZ: f64 = 8000.0;
/// A periodicity starting this much later than the high-passed energy's rise, ms, is the
/// string after a thump.
const THUMP_SHIFT_MS: f64 = 1.0;

/// A second-order Butterworth high-pass (RBJ), run forward then backward: zero phase.
fn highpass_zero_phase(x: &mut [f64], rate: f64, fc: f64) {
    let w = 2.0 * std::f64::consts::PI * fc / rate;
    let (sn, cs) = w.sin_cos();
    let alpha = sn / (2.0 * std::f64::consts::FRAC_1_SQRT_2);
    let a0 = 1.0 + alpha;
    let b = [
        (1.0 + cs) / 2.0 / a0,
        -(1.0 + cs) / a0,
        (1.0 + cs) / 2.0 / a0,
    ];
    let a = [-2.0 * cs / a0, (1.0 - alpha) / a0];
    let pass = |x: &mut [f64]| {
        let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
        for v in x.iter_mut() {
            let y = b[0] * *v + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2;
            x2 = x1;
            x1 = *v;
            y2 = y1;
            y1 = y;
            *v = y;
        }
    };
    pass(x);
    x.reverse();
    pass(x);
    x.reverse();
}

/// A second-order Butterworth low-pass (RBJ), run forward then backward: zero phase.
fn lowpass_zero_phase(x: &mut [f64], rate: f64, fc: f64) {
    let w = 2.0 * std::f64::consts::PI * fc / rate;
    let (sn, cs) = w.sin_cos();
    let alpha = sn / (2.0 * std::f64::consts::FRAC_1_SQRT_2);
    let a0 = 1.0 + alpha;
    let b = [
        (1.0 - cs) / 2.0 / a0,
        (1.0 - cs) / a0,
        (1.0 - cs) / 2.0 / a0,
    ];
    let a = [-2.0 * cs / a0, (1.0 - alpha) / a0];
    let pass = |x: &mut [f64]| {
        let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
        for v in x.iter_mut() {
            let y = b[0] * *v + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2;
            x2 = x1;
            x1 = *v;
            y2 = y1;
            y1 = y;
            *v = y;
        }
    };
    pass(x);
    x.reverse();
    pass(x);
    x.reverse();
}

/// A centred moving sum of `v` over `2 half + 1` points (fewer at the ends), as a function.
fn moving_sum(v: &[f64], half: usize) -> impl Fn(usize) -> f64 + '_ {
    let mut cum = vec![0.0; v.len() + 1];
    for (i, x) in v.iter().enumerate() {
        cum[i + 1] = cum[i] + x;
    }
    move |i: usize| {
        let a = i.saturating_sub(half).min(v.len());
        let b = (i + half + 1).min(v.len());
        (cum[b] - cum[a.min(b)]) / (2 * half + 1) as f64
    }
}

/// The lag, samples, at which the high-passed string `y` repeats best over `range` (its
/// samples after the onset): the whole number of the key's periods `period` (samples) that
/// is at least `min_lag` (samples) long, within ±2 % (a piano's partials run sharp, a
/// string may be off its pitch by some cents).
fn periodic_lag(y: &[f64], range: std::ops::Range<usize>, period: f64, min_lag: f64) -> usize {
    let periods = (min_lag / period).ceil().max(1.0);
    let nominal = periods * period;
    let (lo, hi) = (
        (nominal * 0.98).floor() as usize,
        (nominal * 1.02).ceil() as usize,
    );
    let end = range.end.min(y.len().saturating_sub(hi));
    (lo..=hi)
        .max_by(|&a, &b| {
            let c = |l: usize| (range.start..end).map(|i| y[i] * y[i + l]).sum::<f64>();
            c(a).total_cmp(&c(b))
        })
        .unwrap_or(nominal.round() as usize)
}

/// The first of `lo..hi` from which `f` stays above `level` for `sustain` samples, timed
/// between it and the sample before (`None`: none, or already above at `lo`).
fn first_sustained(
    f: impl Fn(usize) -> f64,
    level: f64,
    lo: usize,
    hi: usize,
    sustain: usize,
) -> Option<f64> {
    let first = (lo..hi)
        .find(|&i| (i..i + sustain).all(|j| f(j) > level))
        .filter(|&i| i > lo)?;
    let (a, b) = (f(first - 1), f(first));
    let frac = if b > a { (level - a) / (b - a) } else { 0.0 };
    Some(first as f64 - 1.0 + frac.clamp(0.0, 1.0))
}

/// A stretch of the recording high-passed at `cutoff_hz` and, if given, low-passed at
/// `top_hz` (both zero-phase): from `from_ms` to `to_ms`, with its first sample's index
/// (`None` if it runs outside the recording).
fn band(
    x: &[f32],
    rate: u32,
    from_ms: f64,
    to_ms: f64,
    cutoff_hz: f64,
    top_hz: Option<f64>,
) -> Option<(Vec<f64>, i64)> {
    let per_ms = f64::from(rate) / 1000.0;
    let from = (from_ms * per_ms).round() as i64;
    let to = (to_ms * per_ms).round() as i64;
    if from < 0 || to as usize > x.len() {
        return None;
    }
    let mut y: Vec<f64> = x[from as usize..to as usize]
        .iter()
        .map(|&v| f64::from(v))
        .collect();
    highpass_zero_phase(&mut y, f64::from(rate), cutoff_hz);
    if let Some(top) = top_hz {
        lowpass_zero_phase(&mut y, f64::from(rate), top);
    }
    Some((y, from))
}

/// Where the string's periodicity starts near `t` (ms) in the recording high-passed at
/// `cutoff_hz`: the product of the signal with itself one lag later (a whole number of the
/// key's periods, at least [`PERIODIC_MIN_LAG_MS`]: [`periodic_lag`]), over a centred 3 ms window, rises
/// a fifth of the way from its level before (the median from 50 to 15 ms before `t`) to its
/// level after (from 2 to 20 ms after), within ±12 ms of `t`, and stays there 5 ms. Before
/// the string that product has no sign of its own (noise, a thump, a click, a room's tail do
/// not repeat at the key's period: a solenoid's thump a few ms before the string is the
/// case); from the string on it is the string's energy. Returns the onset, ms (`None` also
/// where the rise is under [`PERIODIC_CLEAR`]).
fn periodic_onset(
    x: &[f32],
    rate: u32,
    f0: f64,
    t: f64,
    cutoff_hz: f64,
    min_lag_ms: f64,
) -> Option<f64> {
    let per_ms = f64::from(rate) / 1000.0;
    let period = 1000.0 / f0;
    let max_lag_ms = ((min_lag_ms / period).ceil().max(1.0) * period) * 1.03;
    let top_hz = (PERIODIC_TOP_PARTIAL * f0).min(PERIODIC_TOP_HZ);
    let (y, from) = band(
        x,
        rate,
        t - 60.0,
        t + 40.0 + max_lag_ms,
        cutoff_hz,
        Some(top_hz),
    )?;
    let at = |ms: f64| ((ms - (from as f64 / per_ms)) * per_ms).round() as usize;
    let lag = periodic_lag(
        &y,
        at(t + 2.0)..at(t + 30.0),
        period * per_ms,
        min_lag_ms * per_ms,
    );
    let products: Vec<f64> = (0..y.len())
        .map(|i| y.get(i + lag).map_or(0.0, |z| y[i] * z))
        .collect();
    let p = moving_sum(
        &products,
        ((SHARP_WINDOW_MS * per_ms) / 2.0).round() as usize,
    );
    let mut before: Vec<f64> = (at(t - 50.0)..at(t - 15.0)).map(&p).collect();
    let spread = robust_sigma(&before);
    let pre = median(&mut before);
    let post = median(&mut (at(t + 2.0)..at(t + 20.0)).map(&p).collect::<Vec<_>>());
    if post <= pre || post - pre < PERIODIC_CLEAR * spread {
        return None;
    }
    let sustain = (SHARP_SUSTAIN_MS * per_ms).round() as usize;
    let rise = pre + SHARP_FRACTION * (post - pre);
    let i = first_sustained(&p, rise, at(t - 12.0), at(t + 12.0), sustain)?;
    Some((from as f64 + i) / per_ms)
}

/// Where the string is timed once its periodicity starts at `periodic` (ms, measured one
/// lag later: [`periodic_onset`]), the high-passed energy rising at `t_e`: the periodicity
/// a period further on, if it starts earlier and still over [`THUMP_SHIFT_MS`] after
/// `t_e` (a thump's rise), else `periodic`. At one lag the thump's low thud, still ringing
/// under the string's first period, times the string a period later with a sign of its own
/// for a few ms and can hold the periodicity's rise back (F2, 87 Hz, whose lag is one
/// period, 1.7–3.0 ms late in a reverberant room); a period further on the thud has decayed
/// (the lag then is the earliest of the two consistent with the string).
fn string_onset(
    x: &[f32],
    rate: u32,
    f0: f64,
    t: f64,
    cutoff_hz: f64,
    periodic: f64,
    t_e: f64,
) -> f64 {
    let further = PERIODIC_MIN_LAG_MS + 1000.0 / f0;
    match periodic_onset(x, rate, f0, t, cutoff_hz, further) {
        Some(p) if p < periodic && p - t_e > THUMP_SHIFT_MS => p,
        _ => periodic,
    }
}

/// The onset near `t` (ms, the envelope's) timed on the recording high-passed at the key's
/// 4th partial (200 Hz at least, zero-phase): its energy over a centred 3 ms window; its
/// level before (the median from 50 to 15 ms before `t`) and after (from 2 to 20 ms after);
/// the onset where it first rises a fifth of the way from one to the other within ±12 ms of
/// `t`, and stays there 5 ms. Broadband, that rise can be a thump's a few ms before the
/// string: where the string's periodicity in the same band ([`periodic_onset`]) starts more
/// than [`THUMP_SHIFT_MS`] later, the onset is the string's ([`string_onset`]). Returns the onset, how many times the
/// energy rose (`None` if it did not).
pub(crate) fn refine(x: &[f32], rate: u32, note: u8, t: f64) -> Option<Sharp> {
    let per_ms = f64::from(rate) / 1000.0;
    let f0 = 440.0 * 2f64.powf((f64::from(note) - 69.0) / 12.0);
    let cutoff = (SHARP_PARTIAL * f0).max(SHARP_MIN_HZ);
    let (y, from) = band(x, rate, t - 60.0, t + 40.0, cutoff, None)?;
    let at = |ms: f64| ((ms - (from as f64 / per_ms)) * per_ms).round() as usize;
    let sq: Vec<f64> = y.iter().map(|v| v * v).collect();
    let e = moving_sum(&sq, ((SHARP_WINDOW_MS * per_ms) / 2.0).round() as usize);
    let pre = median(&mut (at(t - 50.0)..at(t - 15.0)).map(&e).collect::<Vec<_>>());
    let post = median(&mut (at(t + 2.0)..at(t + 20.0)).map(&e).collect::<Vec<_>>());
    if post <= pre {
        return None;
    }
    let sustain = (SHARP_SUSTAIN_MS * per_ms).round() as usize;
    let rise = pre + SHARP_FRACTION * (post - pre);
    let i = first_sustained(&e, rise, at(t - 12.0), at(t + 12.0), sustain)?;
    let t_e = (from as f64 + i) / per_ms;
    let periodic = periodic_onset(x, rate, f0, t, cutoff, PERIODIC_MIN_LAG_MS)
        .map(|t_p| (t_p, string_onset(x, rate, f0, t, cutoff, t_p, t_e)));
    let t = match periodic {
        Some((t_p, string)) if t_p - t_e > THUMP_SHIFT_MS => string,
        _ => t_e,
    };
    Some(Sharp {
        t,
        periodic,
        // Infinite in digital silence.
        ratio: post / pre,
    })
}
