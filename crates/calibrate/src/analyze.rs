//! A recording of the calibration score in, each key's measurements and figures out.

use serde::Serialize;

use crate::fit::{fit, Fit, Measured};
use crate::listen::{listen, Heard};
use crate::score::{Part, Score, Strike};
use crate::strikes::{analyze_outputs, OutputResult};
use crate::wav::Recording;
use crate::{onset, sync, CalibrateError};

/// A key whose true press delay at full power is known: it fixes the microphone's latency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    /// The key's MIDI note.
    pub note: u8,
    /// Its press delay at full power, ms.
    pub press_delay_ms: f64,
}

impl std::str::FromStr for Anchor {
    type Err = CalibrateError;

    /// `NOTE=MS`, such as `60=14.5`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            CalibrateError::Anchor(format!(
                "{s:?}: write NOTE=MS, a MIDI note and its press delay at full power in ms, \
                 such as 60=14.5"
            ))
        };
        let (n, ms) = s.split_once('=').ok_or_else(bad)?;
        let note: u8 = n.trim().parse().map_err(|_| bad())?;
        let press_delay_ms: f64 = ms
            .trim()
            .trim_end_matches("ms")
            .parse()
            .map_err(|_| bad())?;
        if note > 127 || !(0.0..=1000.0).contains(&press_delay_ms) {
            return Err(bad());
        }
        Ok(Self {
            note,
            press_delay_ms,
        })
    }
}

/// How the press delays were pinned to true time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AnchorUsed {
    /// The key.
    pub note: u8,
    /// Its press delay at full power, ms.
    pub press_delay_ms: f64,
    /// `true`: given with `--anchor`; `false`: the robot file's own value for the key, so every
    /// delay is relative to it (the microphone's latency is unknown).
    pub given: bool,
}

/// One level of one key.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Level {
    /// The velocity asked.
    pub velocity: u8,
    /// The strike duty the robot file plays it at, per cent.
    #[serde(skip)]
    pub duty_percent: f64,
    /// From the asked time to the sound, ms (`null`: no single onset).
    #[serde(serialize_with = "hundredths_or_null")]
    pub press_delay_ms: Option<f64>,
    /// The string's level just after the onset, dB (mean-square; 0 dB is a full-scale
    /// square wave's power).
    #[serde(serialize_with = "hundredths_or_null")]
    pub level_db: Option<f64>,
}

/// A key's figures for robot.toml.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct KeyFigures {
    /// `mechanics.key.press_delay`, ms.
    #[serde(serialize_with = "hundredths")]
    pub press_delay_ms: f64,
    /// `mechanics.key.soft_press_delay`, ms.
    #[serde(serialize_with = "hundredths")]
    pub soft_press_delay_ms: f64,
    /// `mechanics.key.softest`: the softest duty that sounds, per cent (100 on a key
    /// played at full power only).
    #[serde(serialize_with = "hundredths")]
    pub softest_percent: f64,
    /// Whether the key plays velocity (a PWM key): its `[dynamics]` and softest are fitted.
    #[serde(skip)]
    pub dynamics: bool,
}

/// One key's measurements.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KeyResult {
    /// Its MIDI note.
    pub note: u8,
    /// Each level, softest first.
    pub levels: Vec<Level>,
    /// The softest velocity asked that sounded.
    pub softest_velocity: Option<u8>,
    /// What went wrong: strikes with no sound, two onsets, a fit that could not be made.
    pub problems: Vec<String>,
    /// The figures fitted (`null` if the key never sounded once).
    pub fit: Option<KeyFigures>,
}

/// The whole calibration. As JSON (`orch calibrate --json`), the measured figures are
/// rounded to hundredths (of a ms, a dB, a per cent); the anchor's delay is as given.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Calibration {
    /// When the score's time 0 is in the recording, ms (with the anchor: onset = asked time +
    /// press delay + this).
    #[serde(serialize_with = "hundredths")]
    pub capture_offset_ms: f64,
    /// What the delays are pinned to.
    pub anchor: AnchorUsed,
    /// Every key of the robot, lowest first.
    pub keys: Vec<KeyResult>,
    /// Every strike output of the robot, in key order (left out of the JSON when none).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub outputs: Vec<OutputResult>,
    /// What looks wrong with the recording as a whole (strikes after the score's end).
    pub warnings: Vec<String>,
}

impl Calibration {
    /// The keys with problems.
    pub fn keys_with_problems(&self) -> impl Iterator<Item = &KeyResult> {
        self.keys.iter().filter(|k| !k.problems.is_empty())
    }

    /// Every problem, one line each: `note 60: …` for a key, `kick (note 35): …` for a
    /// strike output.
    pub fn problem_lines(&self) -> Vec<String> {
        let keys = self
            .keys_with_problems()
            .map(|k| format!("note {}: {}", k.note, k.problems.join("; ")));
        let outputs = self
            .outputs
            .iter()
            .filter(|o| !o.problems.is_empty())
            .map(|o| format!("{} (note {}): {}", o.name, o.note, o.problems.join("; ")));
        keys.chain(outputs).collect()
    }
}

/// A figure rounded to hundredths, as JSON.
pub(crate) fn hundredths<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64((v * 100.0).round() / 100.0)
}

/// [`hundredths`], or `null`.
fn hundredths_or_null<S: serde::Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(v) => hundredths(v, s),
        None => s.serialize_none(),
    }
}

/// The checks made before listening: silence below this peak, dBFS.
pub const SILENT_DBFS: f64 = -60.0;
/// A sounding second with at least this many full-scale samples is clipped.
const CLIPPED_SAMPLES: u32 = 3;
/// More than this share of sounding seconds clipped: refused.
const CLIPPED_SHARE: f64 = 0.5;

/// Checks the recording as a whole: silence, clipping, length.
pub fn check(rec: &Recording, score: &Score) -> Result<(), CalibrateError> {
    let peak = rec.samples.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let peak_dbfs = 20.0 * f64::from(peak).max(1e-10).log10();
    if peak_dbfs < SILENT_DBFS {
        return Err(CalibrateError::Silent { peak_dbfs });
    }
    let rate = rec.rate as usize;
    let rms: Vec<f64> = rec
        .samples
        .chunks(rate)
        .map(|c| {
            (c.iter().map(|&x| f64::from(x) * f64::from(x)).sum::<f64>() / c.len() as f64).sqrt()
        })
        .collect();
    let loudest = rms.iter().copied().fold(0.0, f64::max);
    let sounding: Vec<usize> = (0..rms.len())
        .filter(|&i| rms[i] >= 0.01 * loudest)
        .collect();
    let clipped = sounding
        .iter()
        .filter(|&&i| rec.clipped_per_second.get(i).copied().unwrap_or(0) >= CLIPPED_SAMPLES)
        .count();
    let share = clipped as f64 / sounding.len().max(1) as f64;
    if share > CLIPPED_SHARE {
        return Err(CalibrateError::Clipped { share });
    }
    let needed_s = f64::from(score.needed_ms()) / 1000.0;
    if rec.seconds() < needed_s {
        return Err(CalibrateError::TooShort {
            recording_s: rec.seconds(),
            needed_s,
        });
    }
    Ok(())
}

/// Analyses a recording of `score` played by `robot`.
pub fn analyze(
    rec: &Recording,
    robot: &orch_robot::Robot,
    score: &Score,
    anchor: Option<Anchor>,
) -> Result<Calibration, CalibrateError> {
    check(rec, score)?;
    let onsets = onset::broadband(rec);
    let offset = locate(rec, score, &onsets)?;
    if let Some(a) = anchor {
        if !score.keys().contains(&a.note) && !score.outputs.iter().any(|o| o.note == a.note) {
            return Err(CalibrateError::Anchor(format!(
                "note {} is not one of the robot's keys ({}..={})",
                a.note, score.low, score.high
            )));
        }
    }
    let schedule = score.schedule();
    let warnings = after_the_end(&onsets, &schedule, offset);
    let (mut keys, fits): (Vec<KeyResult>, Vec<Option<Fit>>) = score
        .keys()
        .map(|note| key(rec, robot, &schedule, offset, (score.low, note)))
        .unzip();
    let mut outputs = analyze_outputs(&rec.samples, rec.rate, robot, score, offset);
    let used = pin(anchor, robot, score, &fits, &outputs)?;
    let shift = used.0.press_delay_ms - used.1;
    shift_delays(&mut keys, &mut outputs, shift);
    Ok(Calibration {
        capture_offset_ms: offset - shift,
        anchor: used.0,
        keys,
        outputs,
        warnings,
    })
}

/// When the score's time 0 is in the recording, ms, from the sync figure among `onsets`; an
/// error if it is not found or the recording ends before the score's last strike has rung.
fn locate(rec: &Recording, score: &Score, onsets: &[onset::Onset]) -> Result<f64, CalibrateError> {
    let found = sync::find(onsets).map_err(|best| CalibrateError::SyncNotFound {
        best,
        of: crate::score::SYNC_MARKS_MS.len(),
    })?;
    let offset = found.offset_ms;
    let last = score.schedule().last().map_or(0, |s| s.at_ms);
    let needed_ms = offset + f64::from(last) + crate::listen::AFTER_MS as f64 + 200.0;
    if rec.seconds() * 1000.0 < needed_ms {
        return Err(CalibrateError::TooShort {
            recording_s: rec.seconds(),
            needed_s: (needed_ms - offset - f64::from(crate::score::LEAD_IN_MS)) / 1000.0,
        });
    }
    Ok(offset)
}

/// Strikes after the score's end: the recording is of a longer score (other --levels,
/// another robot's range), or the room was loud after it. The warning, if any.
fn after_the_end(onsets: &[onset::Onset], schedule: &[Strike], offset: f64) -> Vec<String> {
    let last = schedule.last().map_or(0, |s| s.at_ms);
    let end_s = (offset + f64::from(last) + 700.0) / 1000.0;
    let mut in_score: Vec<f64> = onsets
        .iter()
        .filter(|o| o.t_s <= end_s)
        .map(|o| o.flux)
        .collect();
    let typical = onset::median(&mut in_score);
    let after = onsets
        .iter()
        .filter(|o| o.t_s > end_s && o.flux >= 0.5 * typical)
        .count();
    if after < 3 {
        return Vec::new();
    }
    vec![format!(
        "{after} strikes after the score's end: a recording of a longer score (written with \
         other --levels, or for another robot)? Its analysis is then wrong"
    )]
}

/// One key's strikes heard, measured and fitted (on the analysis' clock): `note`, of a
/// robot whose lowest key is `low`.
fn key(
    rec: &Recording,
    robot: &orch_robot::Robot,
    schedule: &[Strike],
    offset: f64,
    (low, note): (u8, u8),
) -> (KeyResult, Option<Fit>) {
    let strikes: Vec<&Strike> = schedule
        .iter()
        .filter(|s| s.part == Part::Key && s.note == note)
        .collect();
    let expected: Vec<f64> = strikes
        .iter()
        .map(|s| f64::from(s.at_ms) + offset)
        .collect();
    let heard = listen(
        &rec.samples,
        rec.rate,
        note,
        &expected,
        f64::from(crate::score::NOTE_MS),
    );
    let k = note - low;
    let touch = robot.config.dynamics.keys[usize::from(k)];
    let mut problems = Vec::new();
    let (levels, measured): (Vec<Level>, Vec<Measured>) = strikes
        .iter()
        .zip(&heard)
        .map(|(s, h)| level(s, h, &touch, offset, &mut problems))
        .unzip();
    let softest_velocity = levels
        .iter()
        .find(|l| l.press_delay_ms.is_some())
        .map(|l| l.velocity);
    silent_levels(&levels, &measured, softest_velocity, &mut problems);
    let fitted = if softest_velocity.is_none() {
        problems.insert(
            0,
            "no sound at any level: the key is not calibrated".to_string(),
        );
        None
    } else {
        fit_key(
            &levels,
            &measured,
            softest_velocity,
            robot,
            k,
            &mut problems,
        )
    };
    let result = KeyResult {
        note,
        levels,
        softest_velocity,
        problems,
        fit: fitted.map(|f| KeyFigures {
            press_delay_ms: f.press_delay_ms,
            soft_press_delay_ms: f.soft_press_delay_ms,
            softest_percent: f.softest * 100.0,
            dynamics: !touch.is_full(),
        }),
    };
    (result, fitted)
}

/// One strike `s` of a key played with `touch`, as `h` heard it: its level and measurement;
/// more than one onset is a problem.
fn level(
    s: &Strike,
    h: &Heard,
    touch: &orch_core::Touch,
    offset: f64,
    problems: &mut Vec<String>,
) -> (Level, Measured) {
    let duty = f64::from(
        touch
            .strike_duty(orch_core::Velocity::new(s.velocity).expect("1..=127"))
            .get(),
    ) / 4095.0;
    let mut level = Level {
        velocity: s.velocity,
        duty_percent: duty * 100.0,
        press_delay_ms: None,
        level_db: None,
    };
    let mut sound = None;
    let mut level_sigma_db = 0.0;
    match h.onsets_ms.as_slice() {
        [] => {}
        [t] => {
            let d = t - f64::from(s.at_ms) - offset;
            level.press_delay_ms = Some(d);
            level.level_db = h.level_db;
            sound = h.level_db.map(|l| (d, l));
            level_sigma_db = h.level_sigma_db.unwrap_or(0.0);
        }
        many => problems.push(format!(
            "velocity {}: {} onsets for one strike (at {}): not fitted",
            s.velocity,
            many.len(),
            many.iter()
                .map(|t| format!("{:+.1} ms", t - f64::from(s.at_ms) - offset))
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
    let measured = Measured {
        duty,
        sound,
        level_sigma_db,
    };
    (level, measured)
}

/// Strikes with no sound: below the softest (expected, but said), or above it (a fault).
fn silent_levels(
    levels: &[Level],
    measured: &[Measured],
    softest_velocity: Option<u8>,
    problems: &mut Vec<String>,
) {
    for (l, m) in levels.iter().zip(measured) {
        if l.press_delay_ms.is_some()
            || problems
                .iter()
                .any(|p| p.starts_with(&format!("velocity {}:", l.velocity)))
        {
            continue;
        }
        match softest_velocity {
            Some(s) if l.velocity > s => problems.push(format!(
                "velocity {}: no sound, though velocity {s} sounded: not fitted",
                l.velocity
            )),
            Some(_) => problems.push(format!(
                "velocity {}: no sound (duty {:.1} %, below the key's softest)",
                l.velocity,
                m.duty * 100.0
            )),
            None => {}
        }
    }
}

/// The fit of key `k`'s sounding levels (and the silent ones below its softest, which
/// bracket it), the robot file's slope as its prior; its remarks added to `problems`.
fn fit_key(
    levels: &[Level],
    measured: &[Measured],
    softest_velocity: Option<u8>,
    robot: &orch_robot::Robot,
    k: u8,
    problems: &mut Vec<String>,
) -> Option<Fit> {
    // A silent level above a sounding one is a fault, not a bracket: left out.
    let usable: Vec<Measured> = measured
        .iter()
        .zip(levels)
        .filter(|(m, l)| m.sound.is_some() || softest_velocity.is_some_and(|s| l.velocity < s))
        .map(|(m, _)| *m)
        .collect();
    let file = robot.mechanics.for_key(k);
    let slope = file.soft_press_delay.as_micros() as f64 / 1000.0
        - file.press_delay.as_micros() as f64 / 1000.0;
    fit(&usable, slope).map(|(f, remarks)| {
        problems.extend(remarks);
        f
    })
}

/// Every delay and fit moved by `shift`, ms: from the analysis' clock to the anchor's.
fn shift_delays(keys: &mut [KeyResult], outputs: &mut [OutputResult], shift: f64) {
    for k in keys {
        for l in &mut k.levels {
            if let Some(d) = &mut l.press_delay_ms {
                *d += shift;
            }
        }
        if let Some(f) = &mut k.fit {
            f.press_delay_ms += shift;
            f.soft_press_delay_ms += shift;
        }
    }
    for o in outputs {
        for l in &mut o.levels {
            if let Some(d) = &mut l.press_delay_ms {
                *d += shift;
            }
        }
        if let Some(f) = &mut o.fit {
            f.flight_ms += shift;
            f.soft_flight_ms += shift;
        }
    }
}

/// What pins the delays, and its delay as measured (on the analysis' clock): the anchor's
/// key or strike output; without one, the robot file's press delay for middle C (or the
/// key nearest it that sounded), or on a robot without keys the file's flight of its first
/// strike output that sounded.
fn pin(
    anchor: Option<Anchor>,
    robot: &orch_robot::Robot,
    score: &Score,
    fits: &[Option<Fit>],
    outputs: &[OutputResult],
) -> Result<(AnchorUsed, f64), CalibrateError> {
    let low = score.low;
    let key_fit = |n: u8| {
        score
            .keys()
            .contains(&n)
            .then(|| fits[usize::from(n - low)].map(|f| f.press_delay_ms))
    };
    let output_fit = |n: u8| {
        outputs
            .iter()
            .find(|o| o.note == n)
            .map(|o| o.fit.map(|f| f.flight_ms))
    };
    let ms = |d: orch_core::Duration| d.as_micros() as f64 / 1000.0;
    let used = match anchor {
        Some(a) => AnchorUsed {
            note: a.note,
            press_delay_ms: a.press_delay_ms,
            given: true,
        },
        None => {
            let mid = 60u8.clamp(score.low, score.high);
            let key = score
                .keys()
                .filter(|&n| fits[usize::from(n - low)].is_some())
                .min_by_key(|&n| (i16::from(n) - i16::from(mid)).abs());
            match key {
                Some(note) => AnchorUsed {
                    note,
                    press_delay_ms: ms(robot.mechanics.for_key(note - low).press_delay),
                    given: false,
                },
                None => {
                    let o = outputs
                        .iter()
                        .find(|o| o.fit.is_some())
                        .ok_or(CalibrateError::NothingHeard)?;
                    AnchorUsed {
                        note: o.note,
                        press_delay_ms: ms(robot.mechanics.for_key(o.key).press_delay),
                        given: false,
                    }
                }
            }
        }
    };
    let measured = key_fit(used.note)
        .or_else(|| output_fit(used.note))
        .flatten()
        .ok_or_else(|| {
            let what = if score.keys().contains(&used.note) {
                "key"
            } else {
                "the strike output of note"
            };
            CalibrateError::Anchor(format!(
                "{what} {} made no sound, so it cannot anchor the delays; give another key",
                used.note
            ))
        })?;
    Ok((used, measured))
}
