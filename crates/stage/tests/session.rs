//! A live session's public face: a short song on the virtual robot in real time, watched
//! through its snapshots, ended with every robot's performance; and stopped half-way from
//! another thread, every key released and the rest of the notes accounted as stopped.

use std::sync::Arc;
use std::time::{Duration, Instant};

use orch_io::OutSpec;
use orch_perform::{Control, Setup, Tempo};
use orch_robot::Robot;
use orch_seq::Song;
use orch_stage::session::{open_lanes, Session};
use orch_stage::StageError;

use testkit::smf;

fn setup() -> Setup {
    let robot = Robot::thesis();
    Setup::for_robot(&robot)
}

/// 8 quarter notes at 480 BPM: 1 s.
fn song() -> Song {
    Song::parse(&smf::quarters_smf(8, 480.0)).unwrap()
}

#[test]
fn a_session_plays_its_song_shows_where_it_stands_and_ends_with_the_report() {
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup()).unwrap();
    let session = Session::start(song(), lanes, Control::new(), Instant::now());
    let mut seen_down = false;
    let mut last_sent = 0;
    let t0 = Instant::now();
    while !session.is_finished() {
        assert!(t0.elapsed() < Duration::from_secs(20), "never finished");
        if let Some(s) = session.snapshot() {
            seen_down |= s.keys_down.iter().any(|d| *d);
            assert!(s.notes_sent >= last_sent, "notes sent never go back");
            last_sent = s.notes_sent;
            assert_eq!(s.notes, 8);
            assert_eq!(s.low_note, 36);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(seen_down, "a key was seen down");
    let finished = session.finish();
    assert!(finished.failed.is_none());
    assert_eq!(finished.ended.len(), 1);
    let report = finished.ended[0].played.report(None);
    assert!(report.adds_up());
    assert_eq!(report.outcomes.on_time, 8, "{report:?}");
}

#[test]
fn a_session_stopped_from_another_thread_releases_every_key() {
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup()).unwrap();
    let control = Control::new();
    let session = Session::start(
        Song::parse(&smf::quarters_smf(40, 120.0)).unwrap(),
        lanes,
        Arc::clone(&control),
        Instant::now(),
    );
    let stopper = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(1_200));
        control.stop();
    });
    let t0 = Instant::now();
    while !session.is_finished() {
        assert!(t0.elapsed() < Duration::from_secs(20), "never stopped");
        std::thread::sleep(Duration::from_millis(5));
    }
    stopper.join().unwrap();
    assert!(
        t0.elapsed() < Duration::from_secs(10),
        "stopped long before its 20 s end"
    );
    let finished = session.finish();
    let played = &finished.ended[0].played;
    assert!(played.stopped);
    let report = played.report(None);
    assert!(report.adds_up());
    assert!(report.outcomes.dropped.stopped > 20, "{report:?}");
    assert_eq!(
        played.performance.summary.mechanics.stuck_at_end, 0,
        "every key released"
    );
}

#[test]
fn a_bad_output_is_bad_input_in_words() {
    let Err(e) = open_lanes(
        vec![OutSpec::parse("serial:/nonexistent/tty").unwrap()],
        &setup(),
    ) else {
        panic!("opened a missing serial port");
    };
    assert!(
        e.to_string().contains("--out serial:/nonexistent/tty"),
        "{e}"
    );
    assert!(matches!(e, orch_stage::LiveError::BadInput(_)));
}

#[test]
fn viewers_get_the_snapshot_when_they_subscribe_then_each_change_and_a_close_at_the_end() {
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup()).unwrap();
    let control = Control::new();
    let session = Session::start(
        Song::parse(&smf::quarters_smf(16, 480.0)).unwrap(),
        lanes,
        Arc::clone(&control),
        Instant::now(),
    );
    let early = session.subscribe();
    std::thread::sleep(Duration::from_millis(900));
    // Paused, nothing changes: what a viewer subscribing now gets is the snapshot it is
    // given on subscribing, not a change.
    control.pause();
    std::thread::sleep(Duration::from_millis(200));
    let late = session.subscribe();
    let first = late
        .recv_timeout(Duration::from_millis(150))
        .expect("a snapshot on subscribing");
    assert!(first.notes_sent > 0 && first.paused, "{first:?}");
    control.resume();
    let t0 = Instant::now();
    while !session.is_finished() {
        assert!(t0.elapsed() < Duration::from_secs(20));
        std::thread::sleep(Duration::from_millis(5));
    }
    let finished = session.finish();
    assert!(finished.failed.is_none());
    // Both saw the performance to its end, each change once, and then the channel closed.
    let early: Vec<_> = early.iter().collect();
    let late: Vec<_> = late.iter().collect();
    assert!(early.len() > 10, "{} snapshots", early.len());
    assert_eq!(early.last(), late.last());
    assert_eq!(early.last().unwrap().notes_sent, 16);
    for w in early.windows(2) {
        assert_ne!(w[0], w[1], "a snapshot is told only when it changed");
    }
}

#[test]
fn pause_tempo_and_jumps_from_two_threads_at_once_leave_an_account_that_adds_up() {
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup()).unwrap();
    let control = Control::new();
    let song = Song::parse(&smf::quarters_smf(24, 240.0)).unwrap();
    let bar_3 = song.time_at_tick(8 * 480);
    let session = Session::start(song, lanes, Arc::clone(&control), Instant::now());
    let a = {
        let c = Arc::clone(&control);
        std::thread::spawn(move || {
            for _ in 0..3 {
                std::thread::sleep(Duration::from_millis(300));
                c.pause();
                std::thread::sleep(Duration::from_millis(100));
                c.resume();
            }
        })
    };
    let b = {
        let c = Arc::clone(&control);
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(250));
            c.set_tempo(Tempo::new(1.5).unwrap());
            std::thread::sleep(Duration::from_millis(300));
            c.jump_to(bar_3);
            std::thread::sleep(Duration::from_millis(300));
            c.jump_to(0);
        })
    };
    let viewer = session.subscribe();
    let t0 = Instant::now();
    while !session.is_finished() {
        assert!(t0.elapsed() < Duration::from_secs(30), "never finished");
        std::thread::sleep(Duration::from_millis(5));
    }
    a.join().unwrap();
    b.join().unwrap();
    let finished = session.finish();
    let played = &finished.ended[0].played;
    let report = played.report(None);
    assert!(report.adds_up(), "{report:?}");
    assert_eq!(report.jumps, 2, "{report:?}");
    assert!(viewer.iter().any(|s| s.paused), "a viewer saw the pause");
}

/// Waits (at most 10 s) for a snapshot of `session` that `ok` accepts, and gives it.
fn wait_for(
    session: &Session,
    ok: impl Fn(&orch_stage::session::Snapshot) -> bool,
) -> orch_stage::session::Snapshot {
    let t0 = Instant::now();
    loop {
        if let Some(s) = session.snapshot().filter(|s| ok(s)) {
            return s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "never came: {:?}",
            session.snapshot()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn a_jump_to_a_bar_lands_there_and_a_bar_the_song_lacks_is_refused_changing_nothing() {
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup()).unwrap();
    // 6 bars of 4/4 at 120 BPM: 12 s.
    let session = Session::start(
        Song::parse(&smf::quarters_smf(24, 120.0)).unwrap(),
        lanes,
        Control::new(),
        Instant::now(),
    );
    wait_for(&session, |s| s.notes_sent > 0);
    assert!(matches!(
        session.jump_to_bar(7),
        Err(StageError::NoSuchBar { bar: 7, last: 6 })
    ));
    assert_eq!(
        session.jump_to_bar(0).unwrap_err().to_string(),
        "the song has bars 1 to 6"
    );
    assert_eq!(session.jump_to_bar(5).unwrap(), 8_000_000);
    let s = wait_for(&session, |s| s.bar >= 5);
    assert_eq!(s.bar, 5, "landed at the start of bar 5: {s:?}");
    assert_eq!(s.beat, 1);
    session.control().stop();
    let finished = session.finish();
    let report = finished.ended[0].played.report(None);
    assert_eq!(
        report.jumps, 1,
        "the refused jumps changed nothing: {report:?}"
    );
    assert!(report.adds_up());
}

#[test]
fn taps_a_quarter_of_a_second_apart_set_twice_the_written_tempo_and_a_bad_factor_is_refused() {
    let lanes = open_lanes(vec![OutSpec::parse("sim").unwrap()], &setup()).unwrap();
    let origin = Instant::now();
    let session = Session::start(
        Song::parse(&smf::quarters_smf(40, 120.0)).unwrap(),
        lanes,
        Control::new(),
        origin,
    );
    wait_for(&session, |s| s.notes_sent > 0);
    assert!(matches!(
        session.set_tempo(0.0),
        Err(StageError::Tempo(0.0))
    ));
    assert!(matches!(
        session.set_tempo(21.0),
        Err(StageError::Tempo(21.0))
    ));
    assert!(session.set_tempo(f64::NAN).is_err());
    assert_eq!(session.set_tempo(0.5).unwrap().get(), 0.5);
    wait_for(&session, |s| s.tempo == 0.5);
    // Four taps 250 ms apart (240 BPM) on a song written at 120 BPM, the last one now (a
    // second or more into the performance).
    std::thread::sleep(Duration::from_secs(1));
    let now = origin.elapsed().as_micros() as u64;
    let mut bpm = None;
    for i in 0..4u64 {
        bpm = session.tap_at(now - (3 - i) * 250_000);
    }
    let bpm = bpm.expect("a tempo tapped");
    assert!((bpm - 240.0).abs() < 1.0, "{bpm}");
    let s = wait_for(&session, |s| s.tempo != 0.5);
    assert!((s.tempo - 2.0).abs() < 0.02, "{s:?}");
    assert!((s.bpm - 240.0).abs() < 3.0, "{s:?}");
    session.control().stop();
    assert!(session.finish().ended[0].played.report(None).adds_up());
}
