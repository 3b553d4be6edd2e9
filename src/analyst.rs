//! What `orch serve`'s page says of a song and of a performance, as `orch analyze` and `orch
//! play` say it (interim: until the analysis and the reports' text live in `orch-stage`, the
//! page's analysis text is the findings and the report, its end report each robot's report).

use orch_perform::Setup;
use orch_seq::Song;
use orch_stage::session::Finished;

use crate::play::{findings, render, went_wrong};
use crate::robot::Robot;

/// Reads, analyses and reports for the page.
pub struct Analyst {
    robot: Robot,
    setup: Setup,
}

impl Analyst {
    /// For `robot`, played as `setup` says.
    pub fn new(robot: Robot, setup: Setup) -> Self {
        Self { robot, setup }
    }
}

impl orch_serve::Analyst for Analyst {
    fn analyze(&self, name: &str, bytes: &[u8]) -> Result<orch_serve::Analysis, String> {
        let bytes = crate::input::read_midi(bytes, name, crate::input::MAX_MIDI_FILE_BYTES)
            .map_err(|e| e.to_string())?;
        let song =
            Song::parse(&bytes).map_err(|e| format!("{name} is not a playable MIDI file: {e}"))?;
        let mut setup = self.setup.clone();
        setup.sim.keep = orch_sim::Keep::Everything;
        let played = render(&song, &setup).map_err(|e| e.to_string())?;
        let plain = Setup {
            compensation: false,
            ..setup.clone()
        };
        let spread = if setup.compensation {
            Some(orch_perform::Spread::of_onsets(
                &render(&song, &plain).map_err(|e| e.to_string())?.records,
            ))
        } else {
            None
        };
        let report = played.report(spread);
        let wrong = went_wrong(&song, &played, setup.tempo);
        let mut json = serde_json::to_value(&report).map_err(|e| e.to_string())?;
        if let Some(map) = json.as_object_mut() {
            map.insert(
                "went_wrong".into(),
                serde_json::to_value(&wrong).map_err(|e| e.to_string())?,
            );
        }
        let mut text = format!("{name}\n");
        for f in findings(&song, &self.robot, &report) {
            text += &format!("- {f}\n");
        }
        text += "\n";
        text += &report.text();
        let range = self.robot.config.range;
        let roll = orch_roll::build::roll(
            &song,
            &played,
            (range.low().get(), range.high().get()),
            setup.tempo.get(),
            name,
        )
        .map_err(|e| e.to_string())?;
        let svg = orch_roll::render(&roll, &orch_roll::Options::default());
        Ok(orch_serve::Analysis {
            song,
            json,
            text,
            svg,
        })
    }

    fn report(&self, name: &str, finished: &Finished) -> (String, serde_json::Value) {
        let mut text = format!("{name}\n");
        let mut reports = Vec::new();
        for e in &finished.ended {
            let r = e.played.report(None);
            text += &r.text();
            reports.push(serde_json::to_value(&r).unwrap_or_default());
        }
        (text, serde_json::Value::Array(reports))
    }
}
