//! Whether a robot can play a song, and what will go wrong, without playing it: the song
//! performed on the virtual clock, the report (beside the same piece without compensation),
//! the notes that will go wrong, the worst first ([`Wrong`]), and the findings in words
//! ([`crate::findings`]). `orch analyze`'s work; a web page's too.

use orch_perform::{Outcome, Played, Report, Setup, Tempo};
use orch_robot::Robot;
use orch_seq::Song;
use serde::Serialize;

use crate::setup::{play_fast, uncompensated};
use crate::StageError;

/// A note that will go wrong.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Wrong {
    /// Its bar, counted from 1.
    pub bar: u32,
    /// Its beat in the bar, counted from 1.
    pub beat: u32,
    /// The note's name as written ("C4" for 60); on channel 10 its General MIDI drum's
    /// ("Closed Hi-Hat" for 42).
    pub note: String,
    /// 1..=16, as people count channels.
    pub channel: u8,
    /// late, early, joined, unmatched, the drop's reason (`too_soft` among them: no sound),
    /// or, for a note struck on time on a PWM key, `louder` or `softer` (than its velocity, by
    /// more than 2 steps).
    pub outcome: &'static str,
    /// How late or early, ms (late and early only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ms: Option<f64>,
    /// Its velocity in the file (`louder` and `softer` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub velocity: Option<u8>,
    /// How loud it sounded on the velocity scale (`louder` and `softer` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sounded_velocity: Option<u8>,
}

/// What an analysis found. As JSON: the report's fields, then `went_wrong` and `findings`.
#[derive(Clone, Debug, Serialize)]
pub struct Analysis {
    /// How the robot plays it, with the onset error without compensation beside.
    #[serde(flatten)]
    pub report: Report,
    /// The notes that will go wrong, the worst first.
    pub went_wrong: Vec<Wrong>,
    /// What will go wrong, in words (a line each).
    pub findings: Vec<String>,
}

impl Analysis {
    /// As `orch analyze --json` prints it: the report's fields and the notes that went wrong
    /// (the findings are its text's, [`crate::text::analysis`]).
    pub fn json(&self) -> Result<serde_json::Value, serde_json::Error> {
        let mut value = serde_json::to_value(self)?;
        if let Some(map) = value.as_object_mut() {
            map.remove("findings");
        }
        Ok(value)
    }
}

/// Analyses `song` on `robot` as `setup` plays it: the analysis, and the performance it was
/// drawn from (for its account or its roll).
pub fn analyze(
    song: &Song,
    robot: &Robot,
    setup: &Setup,
) -> Result<(Analysis, Played), StageError> {
    let played = play_fast(song, setup)?;
    let report = played.report(uncompensated(song, setup)?);
    let analysis = Analysis {
        went_wrong: went_wrong(song, &played, setup.tempo),
        findings: crate::findings::findings(song, robot, &report),
        report,
    };
    Ok((analysis, played))
}

/// The notes of `played` (a performance of `song` at `tempo`) that went wrong, the worst
/// first. Bars and beats are the song's own: the tempo factor it was played at is undone.
pub fn went_wrong(song: &Song, played: &Played, tempo: Tempo) -> Vec<Wrong> {
    played
        .went_wrong()
        .into_iter()
        .map(|r| {
            let wall = (r.score_at_us - played.start_us as i64).max(0) as f64;
            let (bar, beat) = song.bar_beat((wall * tempo.get()).round() as u64);
            let loudness = match r.outcome {
                Outcome::OnTime { .. } => played.loudness_off(r),
                _ => None,
            };
            Wrong {
                bar,
                beat,
                note: match orch_robot::gm_drum_name(r.note).filter(|_| r.channel == 9) {
                    Some(drum) => drum.to_string(),
                    None => orch_roll::note_name(r.note),
                },
                channel: r.channel + 1,
                outcome: match loudness {
                    Some(true) => "louder",
                    Some(false) => "softer",
                    None => r.outcome.name(),
                },
                velocity: loudness.map(|_| r.velocity),
                sounded_velocity: loudness.and(r.sounded_velocity),
                ms: match r.outcome {
                    Outcome::Late { by_us } | Outcome::Early { by_us } => {
                        Some(by_us as f64 / 1000.0)
                    }
                    _ => None,
                },
            }
        })
        .collect()
}

/// The piano roll of `played` (a performance of `song` on `robot` at `tempo`) as SVG, titled
/// `title` (the file's name). The performance must keep its sound events
/// (`orch_sim::Keep::Everything`) and play straight through (no jump).
pub fn roll_svg(
    song: &Song,
    robot: &Robot,
    played: &Played,
    tempo: Tempo,
    title: &str,
) -> Result<String, orch_roll::build::BuildError> {
    let roll = orch_roll::build::roll_on(song, played, &rows(robot), tempo.get(), title)?;
    Ok(orch_roll::render(&roll, &orch_roll::Options::default()))
}

/// Where the roll draws each of `robot`'s outputs: keys and bars on their pitch's row, a kit's
/// drums on lanes named as the kit names them (kick, snare…); the pitch rows shaded as the
/// robot's span every note its keys and bars play.
fn rows(robot: &Robot) -> orch_roll::build::Rows {
    use orch_roll::build::OutputRow;
    let mut rows = orch_roll::build::Rows::default();
    let (mut low, mut high) = (u8::MAX, 0);
    for g in &robot.groups {
        let kit = g.kind == orch_robot::GroupKind::Kit;
        if kit {
            rows.drum_channels |= robot
                .config
                .strikes
                .group_of(g.first)
                .map_or(0, |s| s.channels.0);
        }
        for (name, notes) in g.outputs.iter().zip(&g.notes) {
            let row = match (g.kind, notes.first()) {
                (_, None) => OutputRow::None,
                (orch_robot::GroupKind::Fingered, Some(_)) => OutputRow::Voice,
                (orch_robot::GroupKind::Kit, _) => {
                    rows.lanes.push(name.clone());
                    OutputRow::Drum(rows.lanes.len() as u16 - 1)
                }
                (orch_robot::GroupKind::Pitched, Some(&n)) => OutputRow::Bar(n),
                (orch_robot::GroupKind::Keyboard, Some(&n)) => OutputRow::Key(n),
            };
            rows.outputs.push(row);
            if !kit {
                for &n in notes {
                    (low, high) = (low.min(n), high.max(n));
                }
            }
        }
    }
    rows.keys = (low <= high).then_some((low, high));
    // As drums are written: cymbals on top, the kick at the bottom.
    let n = rows.lanes.len() as u16;
    rows.lanes.reverse();
    for row in &mut rows.outputs {
        if let OutputRow::Drum(lane) = row {
            *lane = n - 1 - *lane;
        }
    }
    rows
}
