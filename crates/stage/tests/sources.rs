//! The tempo sources' public face: a `--source` text opened and followed to its end, the
//! conductor's status counted, and bad sources refused in words.

use std::sync::{mpsc, Arc, Mutex};
use std::time::Instant;

use orch_perform::{Control, Follow, Follower, ScoreBeats};
use orch_stage::sources::{follow, open_source, source_name, SourceSpec, Stamp, Status};
use orch_stage::SourceError;

use testkit::smf;

fn follower() -> Follower {
    let song = orch_seq::Song::parse(&smf::quarters_smf(32, 120.0)).unwrap();
    Follower::new(ScoreBeats::of(&song), Follow::PHASE)
}

#[test]
fn a_midi_clock_file_is_followed_to_its_end_beat_by_beat() {
    // Start, then 8 quarter notes of clock (24 a quarter), then Stop.
    let mut bytes = vec![0xFA];
    bytes.extend(std::iter::repeat_n(0xF8, 24 * 8));
    bytes.push(0xFC);
    let file = testkit::in_test("clock.bin");
    std::fs::write(&file, &bytes).unwrap();
    let spec = SourceSpec::parse(&format!("midi-clock:{}", file.display())).unwrap();
    assert_eq!(source_name(&spec), "MIDI clock clock.bin");
    let control = Control::new();
    let source = open_source(&spec, &control, Stamp(Instant::now()), None).unwrap();
    let status = Mutex::new(Status::default());
    follow(source, follower(), &control, &status, Stamp(Instant::now()));
    let s = status.lock().unwrap();
    assert_eq!(s.beats, 8, "{s:?}");
    assert!(s.paused, "MIDI Stop pauses the performance");
    assert_eq!(s.ended.as_deref(), Some("its input ended"));
    assert!(s.line("clock").starts_with("conductor clock: 8 beats"));
}

#[test]
fn taps_from_the_view_are_beats() {
    let (tx, rx) = mpsc::channel();
    let control = Arc::new(Control::new());
    let source = open_source(&SourceSpec::Tap, &control, Stamp(Instant::now()), Some(rx)).unwrap();
    for t in [0u64, 500_000, 1_000_000, 1_500_000] {
        tx.send(t).unwrap();
    }
    drop(tx);
    let status = Mutex::new(Status::default());
    follow(source, follower(), &control, &status, Stamp(Instant::now()));
    assert_eq!(status.lock().unwrap().beats, 4);
}

#[test]
fn sources_that_cannot_be_opened_are_bad_input_in_words() {
    let control = Arc::new(Control::new());
    let stamp = Stamp(Instant::now());
    let missing = SourceSpec::parse("midi-clock:/nonexistent/clock").unwrap();
    let Err(SourceError::BadInput(m)) = open_source(&missing, &control, stamp, None) else {
        panic!("opened a missing file");
    };
    assert!(m.contains("/nonexistent/clock"), "{m}");
    let Err(SourceError::BadInput(m)) = open_source(&SourceSpec::Tap, &control, stamp, None) else {
        panic!("a tap source with no keys");
    };
    assert!(m.starts_with("tap"), "{m}");
    let video = SourceSpec::parse("baton:/nonexistent/video.y4m").unwrap();
    assert!(open_source(&video, &control, stamp, None).is_err());
    assert!(SourceSpec::parse("clock:3").is_err());
}
