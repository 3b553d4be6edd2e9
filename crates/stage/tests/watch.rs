//! A session watched to its end by a front end: played through with the front end looking on;
//! from a bar, the notes before it skipped; stopped, every robot, when the front end fails
//! (its error given back) or panics (the panic given back to go on with).

use std::time::{Duration, Instant};

use orch_io::OutSpec;
use orch_perform::{Control, Tempo};
use orch_robot::Robot;
use orch_seq::Song;
use orch_stage::session::open_lanes;
use orch_stage::watch::{self, WatchError};

use testkit::smf;

/// `beats` quarter notes at 480 BPM (8 a second), on the virtual robot.
fn play<E>(
    beats: u32,
    from_bar: Option<u32>,
    watch: impl FnMut(&orch_stage::session::Session) -> Result<(), E>,
) -> watch::Watched<E> {
    let song = Song::parse(&smf::quarters_smf(beats, 480.0)).unwrap();
    let setup = orch_stage::setup::setup(&Robot::thesis(), true, Tempo::NORMAL);
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup).unwrap();
    let from_us = from_bar.map(|b| orch_stage::bars::start_of(&song, b).unwrap());
    watch::play(song, lanes, Control::new(), Instant::now(), from_us, watch)
}

#[test]
fn a_watched_session_plays_to_its_end_from_the_bar_asked() {
    let mut looks = 0;
    let watched = play(8, Some(2), |_| -> Result<(), ()> {
        looks += 1;
        std::thread::sleep(Duration::from_millis(5));
        Ok(())
    });
    assert!(looks > 10, "the front end looked on: {looks} times");
    let Ok(ended) = watched.result else {
        panic!("it failed")
    };
    let report = ended[0].played.report(None);
    assert!(report.adds_up());
    // Bar 2 of 4/4 quarter notes: the first 4 notes are skipped.
    assert_eq!(
        (report.outcomes.on_time, report.outcomes.skipped),
        (4, 4),
        "{report:?}"
    );
}

#[test]
fn a_front_end_that_fails_stops_every_robot_and_gets_its_error_back() {
    let t0 = Instant::now();
    // A minute long: stopped, it ends long before (however slowly a loaded machine goes).
    let watched = play(480, None, |_| {
        std::thread::sleep(Duration::from_millis(5));
        if t0.elapsed() > Duration::from_millis(300) {
            Err("the view went away")
        } else {
            Ok(())
        }
    });
    assert!(
        t0.elapsed() < Duration::from_secs(20),
        "stopped, not played to its end: {:?}",
        t0.elapsed()
    );
    match watched.result {
        Err(WatchError::Front(e)) => assert_eq!(e, "the view went away"),
        _ => panic!("not the front end's error"),
    }
}

#[test]
fn a_front_end_that_panics_stops_every_robot_and_gets_its_panic_back() {
    let t0 = Instant::now();
    let watched = play(480, None, |_| -> Result<(), ()> {
        std::thread::sleep(Duration::from_millis(5));
        assert!(t0.elapsed() < Duration::from_millis(300), "the view broke");
        Ok(())
    });
    // (Its backtrace, if asked for, may take a while to print.)
    assert!(
        t0.elapsed() < Duration::from_secs(20),
        "stopped: {:?}",
        t0.elapsed()
    );
    match watched.result {
        Err(WatchError::Panicked(p)) => {
            assert_eq!(p.downcast_ref::<&str>(), Some(&"the view broke"))
        }
        _ => panic!("not the front end's panic"),
    }
}
