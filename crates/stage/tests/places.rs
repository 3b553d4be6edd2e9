//! The account's bars and beats through a change of tempo mid-performance (a Link session's,
//! a conductor's, the page's): each note's own, not its wall time at the tempo it began at.

use std::sync::Arc;

use orch_io::Channels;
use orch_perform::{song_events, Control, Performer, Tempo};
use orch_robot::Robot;
use orch_seq::{Bell, Clock, Lateness, Song, VirtualClock};
use orch_stage::{account, setup};

/// A virtual clock that asks `control` for `tempo` at the first wait at or after `at_us`.
struct ChangesTempo {
    inner: VirtualClock,
    control: Arc<Control>,
    at_us: u64,
    tempo: Option<Tempo>,
}

impl Clock for ChangesTempo {
    fn now_us(&self) -> u64 {
        self.inner.now_us()
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        if deadline_us >= self.at_us {
            if let Some(t) = self.tempo.take() {
                self.control.set_tempo(t);
            }
        }
        self.inner.wait_until(deadline_us)
    }

    fn wait_until_rung(&mut self, deadline_us: u64, bell: &Bell, seen: u64) -> bool {
        self.wait_until(deadline_us);
        bell.rung() > seen
    }

    fn lateness(&self) -> Lateness {
        self.inner.lateness()
    }
}

#[test]
fn bars_and_beats_stay_the_notes_own_through_a_change_of_tempo() {
    // 16 quarters at 120 BPM (4 bars of 4/4), twice as fast from the second bar on.
    let song = Song::parse(&testkit::smf::quarters_smf(16, 120.0)).unwrap();
    let robot = Robot::thesis();
    let setup = setup::setup(&robot, true, Tempo::NORMAL);
    let control = Control::new();
    let mut clock = ChangesTempo {
        inner: VirtualClock::new(),
        control: Arc::clone(&control),
        at_us: 2_200_000,
        tempo: Tempo::new(2.0),
    };
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .control(&control)
        .clock(&mut clock)
        .run()
        .unwrap();
    assert!(played.records.iter().all(|r| r.sent_us().is_some()));
    let lines = account::account(&song, &played, Channels::ALL, Tempo::NORMAL, None);
    let own: Vec<(u64, u64)> = (0..16).map(|q| (q / 4 + 1, q % 4 + 1)).collect();
    let got: Vec<(u64, u64)> = lines
        .iter()
        .map(|l| (l["bar"].as_u64().unwrap(), l["beat"].as_u64().unwrap()))
        .collect();
    assert_eq!(got, own);
    // The wall times did change pace: the last note came well before 16 quarters at 120.
    let last_ms = lines[15]["t_ms"].as_f64().unwrap();
    assert!(last_ms < 6_000.0, "{last_ms}");
}
