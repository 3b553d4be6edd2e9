//! The strike outputs' part of the analysis: each output's hits heard on the broadband
//! energy (the `hits` module), its flight and loudness fitted.
//!
//! The model is the virtual robot's, as for a key ([`fit`](crate::fit)): a strike at duty
//! `d` sounds at or above the beater's softest duty, its flight is `flight` at full power and
//! `soft_flight` at the softest, linear in the duty between, and its loudness on the velocity
//! scale `1 + 126 (d − softest) / (1 − softest)`. The fit gives the flight at full power, the
//! softest duty the levels say and the level at full power; `soft_flight` is written at the
//! robot file's softest duty for the output (robot.toml has no softest of a strike output),
//! the fitted line read there. On on/off boards every strike is at full power: the flight is
//! the mean of the levels', the file's `soft_flight` is kept.

use serde::Serialize;

use crate::analyze::Level;
use crate::fit::{fit, Measured};
use crate::hits::Energy;
use crate::outputs::Output;
use crate::score::{Part, Score};

/// One strike output's fitted figures (flights on the analysis' clock until pinned).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct OutputFigures {
    /// `flight`, ms: from the pulse's start to the sound at full power.
    #[serde(serialize_with = "crate::analyze::hundredths")]
    pub flight_ms: f64,
    /// `soft_flight`, ms: at the robot file's softest duty for the output.
    #[serde(serialize_with = "crate::analyze::hundredths")]
    pub soft_flight_ms: f64,
    /// The softest duty that sounds as the levels say, per cent (100 on on/off boards).
    #[serde(serialize_with = "crate::analyze::hundredths")]
    pub softest_percent: f64,
    /// The level at full power, dB (mean square over the 30 ms from the onset; 0 dB is a
    /// full-scale square wave's power): the output's loudness against the others'.
    #[serde(serialize_with = "crate::analyze::hundredths")]
    pub full_db: f64,
    /// Whether the output plays velocity as duty (a PWM board): `soft_flight` is fitted.
    #[serde(skip)]
    pub dynamics: bool,
}

/// One strike output's measurements.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutputResult {
    /// Its group's name.
    pub group: String,
    /// Its name (`kick`, `G5`).
    pub name: String,
    /// The robot's output (key index).
    pub key: u8,
    /// Its group's index among the `[[strike]]` tables.
    #[serde(skip)]
    pub strike: usize,
    /// Its index in its group (its `[[strike.output]]` table, or its bar from `low`).
    #[serde(skip)]
    pub index: usize,
    /// The note it was struck with.
    pub note: u8,
    /// The channel it was struck on, 1..=16.
    pub channel: u8,
    /// Each level, softest first.
    pub levels: Vec<Level>,
    /// The softest velocity asked that sounded.
    pub softest_velocity: Option<u8>,
    /// What went wrong: strikes with no sound, a fit that could not be made.
    pub problems: Vec<String>,
    /// The figures fitted (`null` if it never sounded).
    pub fit: Option<OutputFigures>,
}

/// Listens for every strike output of `score` in `rec`, the score's time 0 at `offset_ms`.
pub(crate) fn analyze_outputs(
    samples: &[f32],
    rate: u32,
    robot: &orch_robot::Robot,
    score: &Score,
    offset_ms: f64,
) -> Vec<OutputResult> {
    if score.outputs.is_empty() {
        return Vec::new();
    }
    let energy = Energy::new(samples, rate);
    let schedule = score.schedule();
    score
        .outputs
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let strikes: Vec<(u8, f64)> = schedule
                .iter()
                .filter(|s| s.part == Part::Strike(i))
                .map(|s| (s.velocity, f64::from(s.at_ms)))
                .collect();
            one(&energy, robot, o, &strikes, offset_ms)
        })
        .collect()
}

/// A hit whose peak stands less than this over the level before it, dB, is timed too late
/// to fit a flight with where louder hits are there (rendered through TimGM6mb at 30 dB SNR,
/// the hits at velocity 1, 6–17 dB over the noise, came 1.2–10 ms late; those over 18 dB
/// within 0.5 ms of the virtual robot's flight but for the hi-hat pedal's sample, whose
/// sound starts 3 ms in). Its level still counts.
pub const CLEAR_DB: f64 = 20.0;

/// A flight line: (flight at full power, ms; its rise to the softest, ms).
type Line = (f64, f64);

/// The flight line from the hits clear of the noise, if some were not and at least two
/// were, and the faint hits left out (their index and flight).
fn clear_flights(
    measured: &[Measured],
    clear: &[bool],
    softest: f64,
) -> (Option<Line>, Vec<(usize, f64)>) {
    let x = |d: f64| {
        if softest >= 1.0 {
            0.0
        } else {
            (1.0 - d) / (1.0 - softest)
        }
    };
    let sounding = || {
        measured
            .iter()
            .zip(clear)
            .enumerate()
            .filter(|(_, (m, _))| m.sound.is_some())
    };
    let points: Vec<(f64, f64)> = sounding()
        .filter(|(_, (_, &c))| c)
        .filter_map(|(_, (m, _))| m.sound.map(|(d, _)| (x(m.duty), d)))
        .collect();
    let faint: Vec<(usize, f64)> = sounding()
        .filter(|(_, (_, &c))| !c)
        .filter_map(|(i, (m, _))| m.sound.map(|(d, _)| (i, d)))
        .collect();
    if faint.is_empty() || points.len() < 2 {
        return (None, Vec::new());
    }
    (Some(line(&points)), faint)
}

/// The least-squares line through `points` (x, y): (intercept, slope); flat where the x's do
/// not differ.
fn line(points: &[(f64, f64)]) -> Line {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx < 1e-9 {
        return (my, 0.0);
    }
    let b = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx;
    (my - b * mx, b)
}

/// The strike duty (0..=1) of `velocity` on output `key`.
fn duty(robot: &orch_robot::Robot, key: u8, velocity: u8) -> f64 {
    let touch = robot.config.dynamics.keys[usize::from(key)];
    f64::from(
        touch
            .strike_duty(orch_core::Velocity::new(velocity).expect("1..=127"))
            .get(),
    ) / 4095.0
}

/// One output: its strikes `(velocity, asked ms)`.
fn one(
    energy: &Energy,
    robot: &orch_robot::Robot,
    o: &Output,
    strikes: &[(u8, f64)],
    offset_ms: f64,
) -> OutputResult {
    let mut levels = Vec::new();
    let mut measured = Vec::new();
    let mut clear = Vec::new();
    for &(velocity, at) in strikes {
        let d = duty(robot, o.key, velocity);
        let hit = energy.hit(at + offset_ms);
        clear.push(hit.is_some_and(|h| h.over_db >= CLEAR_DB));
        levels.push(Level {
            velocity,
            duty_percent: d * 100.0,
            press_delay_ms: hit.map(|h| h.onset_ms - at - offset_ms),
            level_db: hit.map(|h| h.level_db),
        });
        measured.push(Measured {
            duty: d,
            sound: hit.map(|h| (h.onset_ms - at - offset_ms, h.level_db)),
            level_sigma_db: hit.map_or(0.0, |h| h.level_sigma_db),
        });
    }
    let softest_velocity = levels
        .iter()
        .find(|l| l.press_delay_ms.is_some())
        .map(|l| l.velocity);
    let mut problems = silent_levels(&levels, softest_velocity);
    let file = robot.mechanics.for_key(o.key);
    let ms = |d: orch_core::Duration| d.as_micros() as f64 / 1000.0;
    let file_softest = f64::from(file.softest) / 4095.0;
    let dynamics = !robot.config.dynamics.keys[usize::from(o.key)].is_full();
    let usable: Vec<Measured> = measured
        .iter()
        .zip(&levels)
        .filter(|(m, l)| m.sound.is_some() || softest_velocity.is_some_and(|s| l.velocity < s))
        .map(|(m, _)| *m)
        .collect();
    let fitted = softest_velocity.and_then(|_| {
        let (mut f, remarks) = fit(&usable, ms(file.soft_press_delay) - ms(file.press_delay))?;
        problems.extend(remarks);
        let (flight, faint) = clear_flights(&measured, &clear, f.softest);
        if let Some((a, b)) = flight {
            f.press_delay_ms = a;
            f.soft_press_delay_ms = a + b;
            problems.extend(faint.iter().map(|(v, d)| {
                format!(
                    "velocity {}: under {CLEAR_DB} dB over the noise, its flight ({d:.1} ms) is \
                     left out of the fit",
                    levels[*v].velocity
                )
            }));
        }
        let soft_flight_ms = if !dynamics || f.softest >= 1.0 {
            ms(file.soft_press_delay) - ms(file.press_delay) + f.press_delay_ms
        } else {
            let x = (1.0 - file_softest) / (1.0 - f.softest);
            f.press_delay_ms + (f.soft_press_delay_ms - f.press_delay_ms) * x
        };
        Some(OutputFigures {
            flight_ms: f.press_delay_ms,
            soft_flight_ms,
            softest_percent: f.softest * 100.0,
            full_db: f.full_db,
            dynamics,
        })
    });
    if softest_velocity.is_none() {
        problems.insert(0, "no sound at any level: not calibrated".into());
    }
    OutputResult {
        group: o.group.clone(),
        name: o.name.clone(),
        key: o.key,
        strike: o.strike,
        index: o.index,
        note: o.note,
        channel: o.channel + 1,
        levels,
        softest_velocity,
        problems,
        fit: fitted,
    }
}

/// The problems of levels that made no sound: below the softest that did (said), or above
/// it (a fault, left out of the fit).
fn silent_levels(levels: &[Level], softest: Option<u8>) -> Vec<String> {
    let Some(s) = softest else {
        return Vec::new();
    };
    levels
        .iter()
        .filter(|l| l.press_delay_ms.is_none())
        .map(|l| {
            if l.velocity > s {
                format!(
                    "velocity {}: no sound, though velocity {s} sounded: not fitted",
                    l.velocity
                )
            } else {
                format!(
                    "velocity {}: no sound (duty {:.1} %, below the output's softest)",
                    l.velocity, l.duty_percent
                )
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(duty: f64, delay: f64) -> Measured {
        Measured {
            duty,
            sound: Some((delay, -20.0)),
            level_sigma_db: 0.0,
        }
    }

    #[test]
    fn a_faint_hit_is_left_out_of_the_flight_line() {
        // Flight 10 ms at full power, 20 at the softest (0.5); the faint softest hit 6 ms late.
        let hits = [m(0.5, 26.0), m(0.75, 15.0), m(1.0, 10.0), m(0.875, 12.5)];
        let (line, faint) = clear_flights(&hits, &[false, true, true, true], 0.5);
        let (a, b) = line.unwrap();
        assert!(
            (a - 10.0).abs() < 1e-9 && (b - 10.0).abs() < 1e-9,
            "{a} {b}"
        );
        assert_eq!(faint, [(0, 26.0)]);
        // All clear, or fewer than two clear: the fit's own line stands.
        assert!(clear_flights(&hits, &[true; 4], 0.5).0.is_none());
        assert!(clear_flights(&hits, &[false, false, false, true], 0.5)
            .0
            .is_none());
    }
}
