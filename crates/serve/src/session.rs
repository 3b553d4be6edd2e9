//! A shared session the page shows and steers (`orch serve --link`): its peers, tempo and
//! start/stop. The session itself is the front end's (an Ableton Link session, through the
//! `orch` binary's `link` feature); this crate sees it through [`Session`], so it links no
//! session library of its own.
//!
//! | method and path | takes | gives |
//! |---|---|---|
//! | `GET /api/session` | | `{"peers", "bpm", "playing"}` (404 without a session) |
//! | `POST /api/session` | `{"start": true}`, `{"stop": true}` or `{"bpm": BPM}` (20–999) | the session's state after it |

use serde::{Deserialize, Serialize};

/// A shared session, as the page needs it.
pub trait Session: Send + Sync {
    /// Its state now.
    fn status(&self) -> SessionStatus;
    /// Starts it playing.
    fn start(&self);
    /// Stops it.
    fn stop(&self);
    /// Sets its tempo, BPM.
    fn set_tempo(&self, bpm: f64);
}

/// A session's state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SessionStatus {
    /// The other peers in it.
    pub peers: u64,
    /// Its tempo, BPM.
    pub bpm: f64,
    /// Whether it plays.
    pub playing: bool,
}

/// The slowest and fastest tempo a session takes (Ableton Link's range).
pub const BPM_RANGE: (f64, f64) = (20.0, 999.0);

/// What the page asks of the session.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionCommand {
    /// Start it.
    #[serde(default)]
    pub start: bool,
    /// Stop it.
    #[serde(default)]
    pub stop: bool,
    /// Set its tempo.
    pub bpm: Option<f64>,
}

impl SessionCommand {
    /// Does it to `session`; a command that asks nothing, or two things at once, or a tempo
    /// out of [`BPM_RANGE`], is refused in words and changes nothing.
    pub fn apply(self, session: &dyn Session) -> Result<SessionStatus, String> {
        match (self.start, self.stop, self.bpm) {
            (true, false, None) => session.start(),
            (false, true, None) => session.stop(),
            (false, false, Some(bpm)) => {
                if !(BPM_RANGE.0..=BPM_RANGE.1).contains(&bpm) {
                    return Err(format!(
                        "bpm {bpm}: a session's tempo is from {} to {} BPM",
                        BPM_RANGE.0, BPM_RANGE.1
                    ));
                }
                session.set_tempo(bpm);
            }
            _ => {
                return Err(
                    "give one of {\"start\": true}, {\"stop\": true}, {\"bpm\": BPM}".into(),
                )
            }
        }
        Ok(session.status())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// A session that keeps what it is told.
    #[derive(Default)]
    struct Kept(Mutex<(bool, f64)>);

    impl Session for Kept {
        fn status(&self) -> SessionStatus {
            let (playing, bpm) = *self.0.lock().unwrap();
            SessionStatus {
                peers: 2,
                bpm,
                playing,
            }
        }
        fn start(&self) {
            self.0.lock().unwrap().0 = true;
        }
        fn stop(&self) {
            self.0.lock().unwrap().0 = false;
        }
        fn set_tempo(&self, bpm: f64) {
            self.0.lock().unwrap().1 = bpm;
        }
    }

    fn command(json: &str) -> SessionCommand {
        serde_json::from_str(json).unwrap()
    }

    #[test]
    fn one_thing_at_a_time_and_a_tempo_in_links_range() {
        let s = Kept::default();
        assert!(command(r#"{"start": true}"#).apply(&s).unwrap().playing);
        assert_eq!(command(r#"{"bpm": 128.5}"#).apply(&s).unwrap().bpm, 128.5);
        for refused in [
            r#"{"bpm": 19.9}"#,
            r#"{"bpm": 1000}"#,
            r#"{}"#,
            r#"{"start": true, "bpm": 90}"#,
        ] {
            assert!(command(refused).apply(&s).is_err(), "{refused}");
        }
        assert_eq!(
            s.status(),
            SessionStatus {
                peers: 2,
                bpm: 128.5,
                playing: true
            }
        );
        assert!(!command(r#"{"stop": true}"#).apply(&s).unwrap().playing);
        assert!(serde_json::from_str::<SessionCommand>(r#"{"tempo": 90}"#).is_err());
    }
}
