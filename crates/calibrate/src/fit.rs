//! Fitting one key's figures to its measured strikes.
//!
//! The model is the virtual robot's ([`orch_sim`'s mechanics](https://docs.rs/orch-sim)):
//! a strike at duty `d` sounds if `d ≥ softest`; its press delay is `press_delay` at full
//! power and `soft_press_delay` at `softest`, linear in the duty between; its loudness on the
//! velocity scale is `1 + 126 (d − softest) / (1 − softest)`. Loudness and sound level are
//! tied as the virtual robot sounds them (`orch render`, [`db_of_loudness`]): loudness 1..=127
//! plays as synthesizer velocity 16..=127, heard at `40 log10(velocity / 127)` dB (the
//! SoundFont convention), a 36 dB range.
//!
//! - **softest**: between the loudest level that made no sound and the softest that did;
//!   within that bracket, the duty whose loudness curve best fits every sounding level
//!   (least squares in dB, the key's full-power level fitted with it), each level weighed by
//!   `1 / (σ² + LEVEL_FLOOR_DB²)` ([`LEVEL_FLOOR_DB`]), σ its noise (from the key's own noise frames, see
//!   [`Measured::level_sigma_db`]): a soft level a few dB over the noise in the key's bins
//!   counts less than the loud ones. With one sounding level it cannot be fitted: the
//!   middle of the bracket, said in the key's problems.
//! - **press delays**: least squares of the delays against `(1 − d) / (1 − softest)`: the
//!   intercept is `press_delay`, intercept plus slope `soft_press_delay`. With one level, the
//!   robot file's slope is kept.

/// One level of a key, as measured.
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    /// The strike duty the robot played it at, 0..=1.
    pub duty: f64,
    /// Its press delay (ms, on the analysis' clock) and level (dB), if it sounded once.
    pub sound: Option<(f64, f64)>,
    /// How far the noise may move that level, dB (one standard deviation; 0 if not known).
    pub level_sigma_db: f64,
}

/// The level's own uncertainty, dB, besides the noise: what the model leaves out (a real
/// key's loudness is not exactly linear in its duty) and what the noise's estimate misses (a
/// level's scatter at 30 dB SNR in a reverberant room is about 0.05 dB where its noise
/// frames say 0.01–0.04): without it the loudest level, nearly noiseless, would outweigh the
/// others without measure.
pub const LEVEL_FLOOR_DB: f64 = 0.1;

/// A key's fitted figures (delays on the analysis' clock, before the anchor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// Press delay at full power, ms.
    pub press_delay_ms: f64,
    /// Press delay at `softest`, ms.
    pub soft_press_delay_ms: f64,
    /// The softest duty that sounds, 0..=1 (1 on a key played at full power only).
    pub softest: f64,
    /// The level at full power, dB.
    pub full_db: f64,
}

/// Velocity-scale loudness of duty `d` on a key whose softest is `s`.
pub fn loudness(d: f64, s: f64) -> f64 {
    if s >= 1.0 {
        return 127.0;
    }
    1.0 + 126.0 * (d - s) / (1.0 - s)
}

/// The synthesizer velocity the virtual robot's loudness 1 sounds at (`orch-render`'s
/// `SOFTEST_VELOCITY`): loudness 1..=127 plays as velocity 16..=127.
pub const SOFTEST_SOUND_VELOCITY: f64 = 16.0;

/// The level in dB, against full power, of a velocity-scale loudness: the virtual robot's
/// sound (`orch render`), loudness `v` played as velocity `u = 16 + 111 (v − 1) / 126` and
/// heard at `40 log10(u / 127)` dB (the SoundFont convention: amplitude as velocity
/// squared), so from −36 dB at loudness 1 to 0 at 127: about a piano's range.
pub fn db_of_loudness(v: f64) -> f64 {
    let u = SOFTEST_SOUND_VELOCITY + (127.0 - SOFTEST_SOUND_VELOCITY) * (v - 1.0) / 126.0;
    40.0 * (u.max(1e-9) / 127.0).log10()
}

/// Fits a key. `file_slope_ms` is `soft_press_delay − press_delay` in the robot file.
/// Returns the fit and any remark for the key's problems; `None` if nothing sounded.
pub fn fit(levels: &[Measured], file_slope_ms: f64) -> Option<(Fit, Vec<String>)> {
    let sounding: Vec<(f64, f64, f64)> = levels
        .iter()
        .filter_map(|m| m.sound.map(|(d, l)| (m.duty, d, l)))
        .collect();
    // Each level weighed by its uncertainty: a soft level near the noise counts less.
    let weight: Vec<f64> = levels
        .iter()
        .filter(|m| m.sound.is_some())
        .map(|m| 1.0 / (m.level_sigma_db.powi(2) + LEVEL_FLOOR_DB.powi(2)))
        .collect();
    let total_weight: f64 = weight.iter().sum();
    if sounding.is_empty() {
        return None;
    }
    let mut remarks = Vec::new();
    let hi = sounding.iter().map(|s| s.0).fold(f64::INFINITY, f64::min);
    let lo = levels
        .iter()
        .filter(|m| m.sound.is_none() && m.duty < hi)
        .map(|m| m.duty)
        .fold(0.0, f64::max);
    let duties_differ = sounding.iter().any(|s| (s.0 - hi).abs() > 1e-9);
    let (softest, full_db) = if !duties_differ {
        if hi >= 1.0 - 1e-9 && levels.iter().all(|m| m.duty >= 1.0 - 1e-9) {
            // Played at full power only (an on/off key): nothing to fit.
            let full = sounding.iter().map(|s| s.2).sum::<f64>() / sounding.len() as f64;
            (1.0, full)
        } else {
            let s = 0.5 * (lo + hi);
            remarks.push(format!(
                "one sounding level: its softest duty lies between {:.1} % and {:.1} %, \
                 taken as {:.1} %",
                lo * 100.0,
                hi * 100.0,
                s * 100.0
            ));
            let full = sounding[0].2 - db_of_loudness(loudness(hi, s));
            (s, full)
        }
    } else {
        let mut best = (f64::INFINITY, hi, 0.0);
        let steps = ((hi - lo) / 0.0002).ceil().max(1.0) as usize;
        for k in 1..=steps {
            let s = (lo + (hi - lo) * k as f64 / steps as f64).min(hi);
            let model: Vec<f64> = sounding
                .iter()
                .map(|x| db_of_loudness(loudness(x.0, s)))
                .collect();
            let full = sounding
                .iter()
                .zip(&model)
                .zip(&weight)
                .map(|((x, m), w)| w * (x.2 - m))
                .sum::<f64>()
                / total_weight;
            let err: f64 = sounding
                .iter()
                .zip(&model)
                .zip(&weight)
                .map(|((x, m), w)| w * (x.2 - full - m).powi(2))
                .sum();
            if err < best.0 {
                best = (err, s, full);
            }
        }
        (best.1, best.2)
    };
    // Press delays against x = (1 - d) / (1 - softest).
    let xs: Vec<(f64, f64)> = sounding
        .iter()
        .map(|s| {
            let x = if softest >= 1.0 {
                0.0
            } else {
                (1.0 - s.0) / (1.0 - softest)
            };
            (x, s.1)
        })
        .collect();
    let n = xs.len() as f64;
    let mx = xs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = xs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = xs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let (a, b) = if sxx > 1e-9 {
        let b = xs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
        (my - b * mx, b)
    } else {
        let b = if softest >= 1.0 { 0.0 } else { file_slope_ms };
        (my - b * mx, b)
    };
    Some((
        Fit {
            press_delay_ms: a,
            soft_press_delay_ms: a + b,
            softest,
            full_db,
        },
        remarks,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(duty: f64, s: f64, pd: f64, spd: f64, full: f64) -> Measured {
        Measured {
            duty,
            level_sigma_db: 0.0,
            sound: (duty >= s).then(|| {
                (
                    pd + (spd - pd) * (1.0 - duty) / (1.0 - s),
                    full + db_of_loudness(loudness(duty, s)),
                )
            }),
        }
    }

    #[test]
    fn exact_levels_give_back_the_key() {
        let duties = [0.45, 0.633, 0.817, 1.0];
        let m: Vec<_> = duties
            .iter()
            .map(|&d| level(d, 0.55, 12.0, 31.0, -20.0))
            .collect();
        let (f, remarks) = fit(&m, 15.0).unwrap();
        assert!(remarks.is_empty());
        assert!((f.softest - 0.55).abs() < 0.001, "{f:?}");
        assert!((f.press_delay_ms - 12.0).abs() < 0.01, "{f:?}");
        assert!((f.soft_press_delay_ms - 31.0).abs() < 0.05, "{f:?}");
        assert!((f.full_db + 20.0).abs() < 0.01, "{f:?}");
    }

    #[test]
    fn one_sounding_level_is_bracketed_and_said() {
        let m = [
            level(0.817, 0.9, 10.0, 20.0, 0.0),
            level(1.0, 0.9, 10.0, 20.0, 0.0),
        ];
        let (f, remarks) = fit(&m, 15.0).unwrap();
        assert!((f.softest - 0.9085).abs() < 0.001);
        assert_eq!(remarks.len(), 1);
        assert!(fit(&[level(0.5, 0.9, 1.0, 2.0, 0.0)], 1.0).is_none());
    }

    #[test]
    fn a_noisy_soft_level_counts_less() {
        // The soft level 1 dB too loud: unweighted, the softest moves with it; said to be
        // 2 dB noisy, the loud levels keep it near the truth.
        let duties = [0.45, 0.633, 0.817, 1.0];
        let mut m: Vec<_> = duties
            .iter()
            .map(|&d| level(d, 0.55, 12.0, 31.0, -20.0))
            .collect();
        m[1].sound = m[1].sound.map(|(d, l)| (d, l + 1.0));
        let plain = fit(&m, 15.0).unwrap().0.softest;
        m[1].level_sigma_db = 2.0;
        let weighed = fit(&m, 15.0).unwrap().0.softest;
        assert!((plain - 0.55).abs() > 0.004, "{plain}");
        assert!(
            (weighed - 0.55).abs() < 0.3 * (plain - 0.55).abs(),
            "{weighed} {plain}"
        );
    }
}
