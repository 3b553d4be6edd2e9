//! The session builder: a live play paced by the clock a front end plugs in (one a robot),
//! steered by its control, with what it was told checked before anything plays.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use orch_perform::Control;
use orch_seq::{Clock, VirtualClock};
use orch_stage::play::{Play, PlayError};

/// `beats` quarter notes at 120 BPM written to a file of its own.
fn song_file(name: &str, beats: u32) -> PathBuf {
    let path = testkit::in_test(&format!("{name}.mid"));
    std::fs::write(&path, testkit::smf::quarters_smf(beats, 120.0)).unwrap();
    path
}

#[test]
fn a_live_play_is_paced_by_the_clock_plugged_in_one_a_robot() {
    let file = song_file("clock", 8);
    let made = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&made);
    let started = Instant::now();
    let performed = Play::file(&file)
        .outs(["sim", "sim:ch=1"])
        .clock(move || -> Box<dyn Clock + Send> {
            counted.fetch_add(1, Ordering::SeqCst);
            Box::new(VirtualClock::new())
        })
        .run()
        .unwrap();
    assert_eq!(made.load(Ordering::SeqCst), 2, "one clock a robot");
    assert_eq!(performed.ended.len(), 2);
    // Four seconds of music on the virtual clock: far less on the wall's.
    assert!(
        started.elapsed().as_secs_f64() < 2.0,
        "{:?}",
        started.elapsed()
    );
    for e in &performed.ended {
        assert_eq!(e.played.report(None).outcomes.on_time, 8);
    }
}

#[test]
fn a_play_steered_by_a_stopped_control_ends_at_once_and_reports() {
    let file = song_file("steer", 64);
    let control = Control::new();
    control.stop();
    let performed = Play::file(&file)
        .steered_by(Arc::clone(&control), Instant::now())
        .run()
        .unwrap();
    let report = performed.reports();
    let orch_stage::Reports::One(report) = report else {
        panic!("one robot, no output named")
    };
    assert!(report.outcomes.on_time < 64, "stopped before the end");
}

#[test]
fn what_a_play_is_told_is_checked_before_it_plays() {
    let file = song_file("checks", 8);
    let e = Play::file(&file)
        .from_bar(9)
        .fast(true)
        .run()
        .err()
        .expect("refused");
    assert!(matches!(e, PlayError::From { bar: 9, .. }), "{e}");
    let e = Play::file(&file)
        .tempo(100.0)
        .fast(true)
        .run()
        .err()
        .expect("refused");
    assert!(matches!(e, PlayError::Tempo { .. }), "{e}");
    let e = Play::file(&file)
        .outs(["udp:127.0.0.1:9"])
        .fast(true)
        .run()
        .err()
        .expect("refused");
    assert!(
        matches!(e, PlayError::FastOut(ref out) if out == "udp:127.0.0.1:9"),
        "{e}"
    );
    assert!(e.is_bad_input());
}
