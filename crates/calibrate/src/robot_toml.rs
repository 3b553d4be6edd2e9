//! The calibrated robot.toml: the input file's settings, with `[[mechanics.key]]` and
//! `[[dynamics.key]]` entries filled from the fit.
//!
//! For each key that was fitted: `mechanics.key`'s `press_delay` (and on a PWM key its
//! `soft_press_delay` and `softest`); on a PWM key, `dynamics.key`'s `softest` (the fitted
//! softest plus [`SOFTEST_MARGIN_STEPS`] of the key's own velocity steps, so velocity 1 still
//! sounds when the fit is a little low), `loudest` = 100 % (velocity 127 at full power: then the loudness heard is the
//! velocity asked) and `hold` (the file's, lowered to the softest if it was above it). Other
//! fields of a key's entries are kept; keys not fitted keep what the file gave them.
//! Comments of the input file are not kept. Strike outputs: see `robot_strikes`.

use crate::analyze::Calibration;
use crate::CalibrateError;

/// Added to a key's fitted softest duty for its velocity curve, in the key's own velocity
/// steps (one step is `(1 − softest) / 126` of full power): so velocity 1 still sounds when
/// the fit comes out a little low.
///
/// A curve that starts `m` steps above the key's true softest is `m` steps loud at velocity
/// 1 and exact at 127 (linear between), and one that starts below it leaves velocity 1
/// silent; so a curve within 3 steps needs the written softest within 0 to 3 steps above
/// the true one, and a margin of 1.5 steps puts the fit's error in the middle of that, ±1.5
/// steps either way. (A fixed share of full power, 0.5 % before, is 1.05 steps on a key
/// whose softest is 40 % but 2.5 on one at 75 %: its curve went over 3 steps when the fit
/// was 0.1 % high.)
pub const SOFTEST_MARGIN_STEPS: f64 = 1.5;

/// The softest duty written in `[[dynamics.key]]` for a fitted softest, per cent: the fit
/// plus [`SOFTEST_MARGIN_STEPS`] of the key's velocity steps.
pub fn written_softest_percent(fitted_percent: f64) -> f64 {
    let step = (100.0 - fitted_percent).max(0.0) / 126.0;
    (fitted_percent + SOFTEST_MARGIN_STEPS * step).min(100.0)
}

/// The calibrated robot.toml for the robot file `input` (its text).
pub fn calibrated(input: &str, cal: &Calibration) -> Result<String, CalibrateError> {
    use toml::{Table, Value};
    let robot = orch_robot::Robot::from_toml(input)
        .map_err(|e| CalibrateError::Internal(format!("the input robot.toml: {e}")))?;
    let mut doc: Table = input
        .parse()
        .map_err(|e| CalibrateError::Internal(format!("the input robot.toml: {e}")))?;
    let low = robot.config.range.low().get();
    let default_hold = |note: u8| {
        f64::from(
            robot.config.dynamics.keys[usize::from(note - low)]
                .hold
                .percent(),
        )
    };
    let section = |doc: &mut Table, name: &str| -> Vec<Table> {
        let t = doc
            .entry(name)
            .or_insert_with(|| Value::Table(Table::new()))
            .as_table_mut()
            .expect("the robot file's section is a table");
        t.remove("key")
            .and_then(|v| match v {
                Value::Array(a) => Some(
                    a.into_iter()
                        .filter_map(|e| match e {
                            Value::Table(t) => Some(t),
                            _ => None,
                        })
                        .collect(),
                ),
                _ => None,
            })
            .unwrap_or_default()
    };
    let mut mech = section(&mut doc, "mechanics");
    let mut dyns = section(&mut doc, "dynamics");
    fn entry(list: &mut Vec<Table>, note: u8) -> &mut Table {
        let i = match list
            .iter()
            .position(|t| t.get("note").and_then(Value::as_integer) == Some(i64::from(note)))
        {
            Some(i) => i,
            None => {
                let mut t = Table::new();
                t.insert("note".into(), Value::Integer(i64::from(note)));
                list.push(t);
                list.len() - 1
            }
        };
        &mut list[i]
    }
    let ms = |x: f64| Value::String(format!("{:.1}ms", x.max(0.0)));
    let pct = |x: f64| Value::String(format!("{:.2}%", x.clamp(0.01, 100.0)));
    for k in &cal.keys {
        let Some(f) = k.fit else { continue };
        let m = entry(&mut mech, k.note);
        m.insert("press_delay".into(), ms(f.press_delay_ms));
        if f.dynamics {
            m.insert(
                "soft_press_delay".into(),
                ms(f.soft_press_delay_ms.max(f.press_delay_ms)),
            );
            m.insert("softest".into(), pct(f.softest_percent));
            let softest = written_softest_percent(f.softest_percent);
            let d = entry(&mut dyns, k.note);
            d.insert("softest".into(), pct(softest));
            d.insert("loudest".into(), pct(100.0));
            let hold = d
                .get("hold")
                .and_then(Value::as_str)
                .and_then(|h| h.trim().trim_end_matches('%').trim().parse::<f64>().ok())
                .unwrap_or_else(|| default_hold(k.note));
            d.insert("hold".into(), pct(hold.min(softest)));
        }
    }
    crate::robot_strikes::write(&mut doc, &cal.outputs);
    let by_note = |t: &Table| t.get("note").and_then(Value::as_integer).unwrap_or(0);
    mech.sort_by_key(by_note);
    dyns.sort_by_key(by_note);
    for (name, list) in [("mechanics", mech), ("dynamics", dyns)] {
        if !list.is_empty() {
            doc[name].as_table_mut().expect("a table").insert(
                "key".into(),
                Value::Array(list.into_iter().map(Value::Table).collect()),
            );
        }
    }
    let body = toml::to_string(&doc)
        .map_err(|e| CalibrateError::Internal(format!("writing robot.toml: {e}")))?;
    let a = cal.anchor;
    let mut head = String::from("# robot.toml calibrated by `orch calibrate` from a recording.\n");
    if a.given {
        head += &format!(
            "# Press delays pinned by the anchor: note {} = {} ms at full power.\n",
            a.note, a.press_delay_ms
        );
    } else {
        head += &format!(
            "# Press delays are RELATIVE to note {}'s press_delay in the input robot.toml \
             ({} ms): the microphone's latency is unknown. Give --anchor NOTE=MS for true ones.\n",
            a.note, a.press_delay_ms
        );
    }
    for w in &cal.warnings {
        head += &format!("# WARNING: {w}\n");
    }
    head += &crate::robot_strikes::loudness_comments(&cal.outputs);
    for line in cal.problem_lines() {
        head += &format!("# {line}\n");
    }
    let text = format!("{head}\n{body}");
    orch_robot::Robot::from_toml(&text).map_err(|e| {
        CalibrateError::Internal(format!("the calibrated robot.toml does not load: {e}"))
    })?;
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_margin_is_in_the_keys_own_steps() {
        // 1.5 steps of (100 − softest) / 126 each.
        assert!((written_softest_percent(40.0) - (40.0 + 1.5 * 60.0 / 126.0)).abs() < 1e-9);
        assert!((written_softest_percent(75.0) - (75.0 + 1.5 * 25.0 / 126.0)).abs() < 1e-9);
        assert_eq!(written_softest_percent(100.0), 100.0);
    }
}
