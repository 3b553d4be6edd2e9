//! The strike outputs' part of the calibrated robot.toml: each fitted output's `flight` (and
//! on a PWM board its `soft_flight`) written into its `[[strike.output]]` table; a pitched
//! group, whose bars have no tables of their own, gets the median of its bars' figures in its
//! `[[strike]]` table. robot.toml has no loudness of a strike output: each group's outputs'
//! levels at full power, against its loudest, are written as a comment.

use toml::{Table, Value};

use crate::strikes::OutputResult;

/// Writes the fitted flights of `outputs` into `doc` (the robot file's tables).
pub(crate) fn write(doc: &mut Table, outputs: &[OutputResult]) {
    let ms = |x: f64| Value::String(format!("{:.1}ms", x.max(0.0)));
    let Some(Value::Array(groups)) = doc.get_mut("strike") else {
        return;
    };
    for (g, group) in groups.iter_mut().enumerate() {
        let Value::Table(group) = group else { continue };
        let mine: Vec<&OutputResult> = outputs.iter().filter(|o| o.strike == g).collect();
        if let Some(Value::Array(tables)) = group.get_mut("output") {
            for o in &mine {
                let (Some(f), Some(Value::Table(t))) = (o.fit, tables.get_mut(o.index)) else {
                    continue;
                };
                t.insert("flight".into(), ms(f.flight_ms));
                if f.dynamics {
                    t.insert("soft_flight".into(), ms(f.soft_flight_ms.max(f.flight_ms)));
                }
            }
        } else {
            let fits: Vec<_> = mine.iter().filter_map(|o| o.fit).collect();
            if fits.is_empty() {
                continue;
            }
            let mut flight: Vec<f64> = fits.iter().map(|f| f.flight_ms).collect();
            let mut soft: Vec<f64> = fits.iter().map(|f| f.soft_flight_ms).collect();
            let flight = crate::onset::median(&mut flight);
            group.insert("flight".into(), ms(flight));
            if fits[0].dynamics {
                let soft = crate::onset::median(&mut soft);
                group.insert("soft_flight".into(), ms(soft.max(flight)));
            }
        }
    }
}

/// Comment lines: each group's outputs' levels at full power against its loudest, dB.
pub(crate) fn loudness_comments(outputs: &[OutputResult]) -> String {
    let mut groups: Vec<&str> = outputs.iter().map(|o| o.group.as_str()).collect();
    groups.dedup();
    let mut out = String::new();
    for g in groups {
        let fitted: Vec<(&str, f64)> = outputs
            .iter()
            .filter(|o| o.group == g)
            .filter_map(|o| o.fit.map(|f| (o.name.as_str(), f.full_db)))
            .collect();
        let Some(loudest) = fitted.iter().map(|x| x.1).reduce(f64::max) else {
            continue;
        };
        let list: Vec<String> = fitted
            .iter()
            .map(|(n, db)| format!("{n} {:+.1}", db - loudest))
            .collect();
        out += &format!(
            "# {g}: loudness at full power, dB against its loudest output: {}\n",
            list.join(", ")
        );
    }
    out
}
