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

#[cfg(test)]
mod tests {
    use crate::analyze::{AnchorUsed, Calibration};
    use crate::strikes::{OutputFigures, OutputResult};
    use orch_robot::{BoardKind, Instrument, Robot};

    fn output(strike: usize, index: usize, name: &str, flight: f64, full_db: f64) -> OutputResult {
        OutputResult {
            group: "g".into(),
            name: name.into(),
            key: index as u8,
            strike,
            index,
            note: 79 + index as u8,
            channel: 1,
            levels: Vec::new(),
            softest_velocity: Some(43),
            problems: Vec::new(),
            fit: Some(OutputFigures {
                flight_ms: flight,
                soft_flight_ms: flight + 5.0,
                softest_percent: 50.0,
                full_db,
                dynamics: true,
            }),
        }
    }

    fn calibration(outputs: Vec<OutputResult>) -> Calibration {
        Calibration {
            capture_offset_ms: 0.0,
            anchor: AnchorUsed {
                note: 79,
                press_delay_ms: 6.0,
                given: true,
            },
            keys: Vec::new(),
            outputs,
            warnings: Vec::new(),
        }
    }

    #[test]
    fn a_glockenspiel_gets_its_bars_median_flights_and_a_kit_each_outputs() {
        let glock = crate::robot_toml::calibrated(
            &orch_robot::instrument_toml(Instrument::Glockenspiel, BoardKind::Pwm),
            &calibration(vec![
                output(0, 0, "G5", 4.0, -10.0),
                output(0, 1, "G#5", 7.0, -12.0),
                output(0, 2, "A5", 9.0, -16.5),
            ]),
        )
        .unwrap();
        let robot = Robot::from_toml(&glock).unwrap();
        let m = robot.mechanics.for_key(0);
        assert_eq!(m.press_delay.as_micros(), 7000, "{glock}");
        assert_eq!(m.soft_press_delay.as_micros(), 12_000);
        assert!(glock.contains("G5 +0.0, G#5 -2.0, A5 -6.5"), "{glock}");
        let drums = crate::robot_toml::calibrated(
            &orch_robot::instrument_toml(Instrument::Drums, BoardKind::OnOff),
            &calibration(vec![output(0, 1, "snare", 12.3, -3.0)]),
        )
        .unwrap();
        let robot = Robot::from_toml(&drums).unwrap();
        assert_eq!(robot.mechanics.for_key(1).press_delay.as_micros(), 12_300);
        // An output not fitted keeps the file's flight (the kick: 15 ms).
        assert_eq!(robot.mechanics.for_key(0).press_delay.as_micros(), 15_000);
    }
}
