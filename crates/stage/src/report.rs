//! Every robot's report at the end of a performance, as a front end shows it: one robot's
//! [`Report`] alone, or each robot's with where it played, the channels it took and its
//! output's figures ([`Reports`]). JSON through serde; text through [`crate::text`].

use orch_io::OutStats;
use orch_perform::Report;
use serde::ser::{SerializeMap, Serializer};
use serde::Serialize;

use crate::session::Ended;

/// What happened on an output, for the report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum LinkFigures {
    /// A MIDI port (a DIN line, raw MIDI, UDP).
    Port {
        /// Bytes sent.
        bytes: u64,
        /// Writes made.
        writes: u64,
        /// Times the device went away.
        lost: u64,
        /// Times it came back.
        reconnected: u64,
        /// Bytes not sent while it was away.
        dropped_bytes: u64,
    },
    /// Finger boards on an I2C bus.
    Boards {
        /// Writes tried again.
        retries: u64,
        /// Writes that failed.
        failed_writes: u64,
        /// Times a board was lost.
        boards_lost: u64,
        /// Times a lost board was initialised again.
        boards_reinitialised: u64,
    },
}

impl From<OutStats> for LinkFigures {
    fn from(s: OutStats) -> Self {
        match s {
            OutStats::Port(p) => LinkFigures::Port {
                bytes: p.bytes,
                writes: p.writes,
                lost: p.lost,
                reconnected: p.reconnected,
                dropped_bytes: p.dropped_bytes,
            },
            OutStats::Boards(b) => LinkFigures::Boards {
                retries: b.retries,
                failed_writes: b.failed_writes,
                boards_lost: b.lost,
                boards_reinitialised: b.reinitialised,
            },
        }
    }
}

/// One robot's report: where it played, the channels it took, its output's figures.
#[derive(Clone, Debug, Serialize)]
pub struct RobotReport {
    /// The output as given (`sim`, `serial:…`).
    pub out: String,
    /// The channels it took, 1..=16, comma-separated.
    pub channels: String,
    /// What happened on its output (none for the virtual robot alone).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub link: Option<LinkFigures>,
    /// How it played.
    #[serde(flatten)]
    pub report: Report,
}

impl RobotReport {
    /// The robot's report from its end of the session.
    pub fn of(ended: &Ended) -> Self {
        Self {
            out: ended.spec.text.clone(),
            channels: ended.spec.channels.to_string(),
            link: ended.stats.map(LinkFigures::from),
            report: ended.played.report(None),
        }
    }

    /// How many times its output's device went away (a port's; 0 otherwise).
    pub fn times_lost(&self) -> u64 {
        match self.link {
            Some(LinkFigures::Port { lost, .. }) => lost,
            _ => 0,
        }
    }
}

/// Every robot's report: the virtual robot's alone when it played alone and no output was
/// named, each robot's with its output otherwise.
///
/// As JSON: the report itself; one named robot's object; or `{"robots": [...]}`.
#[derive(Clone, Debug)]
pub enum Reports {
    /// The one robot's report, no output named.
    One(Box<Report>),
    /// Each robot's, with where it played.
    Robots(Vec<RobotReport>),
}

impl Reports {
    /// The reports of a session's robots; `named` is whether outputs were named (`--out`):
    /// then every robot's report says where it played, even one alone.
    pub fn of(ended: &[Ended], named: bool) -> Self {
        match ended {
            [one] if !named => Reports::One(Box::new(one.played.report(None))),
            _ => Reports::Robots(ended.iter().map(RobotReport::of).collect()),
        }
    }
}

impl Serialize for Reports {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Reports::One(r) => r.serialize(s),
            Reports::Robots(robots) => match robots.as_slice() {
                [one] => one.serialize(s),
                _ => {
                    let mut map = s.serialize_map(Some(1))?;
                    map.serialize_entry("robots", robots)?;
                    map.end()
                }
            },
        }
    }
}
