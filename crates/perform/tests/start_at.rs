//! A start at a moment given (`Control::start_at`), as a shared session's bar line asks: the
//! first place (score time 0, or the target of a jump asked before the start) sounds at that
//! moment, the notes before a target skipped, and a moment too soon taken as soon as can be.

use std::sync::Arc;

use orch_perform::{song_events, Control, Link, Outcome, Performer, Played, WallTime};

mod common;
use common::{corpus_song, setup};

fn play(control: &Arc<Control>) -> Played {
    play_with(control, true)
}

fn play_with(control: &Arc<Control>, compensation: bool) -> Played {
    let song = corpus_song("bach-invention-01.mid");
    let mut setup = setup(Link::Direct);
    setup.compensation = compensation;
    Performer::new(&setup, song_events(&song), song.notes())
        .control(control)
        .run()
        .unwrap()
}

/// The first record that sounded: its score time (wall µs) and its error.
fn first_sounded(played: &Played) -> (i64, i32) {
    played
        .records
        .iter()
        .find_map(|r| match r.outcome {
            Outcome::OnTime { error_us } => Some((r.score_at_us, error_us)),
            _ => None,
        })
        .expect("a note sounded")
}

#[test]
fn the_first_note_sounds_at_the_moment_asked() {
    let control = Control::new();
    control.start_at(WallTime::from_micros(2_500_000));
    let played = play(&control);
    let (at, error) = first_sounded(&played);
    // The invention's first note is at score time 0 (a sixteenth rest before it: see below).
    let first_score = corpus_song("bach-invention-01.mid")
        .events()
        .iter()
        .find_map(|e| e.bytes.note_on().map(|_| e.time_us));
    assert_eq!(at, 2_500_000 + first_score.unwrap() as i64);
    assert!(error.abs() <= 1_000, "{error}");
    assert_eq!(control.time_map().unwrap().wall(0), 2_500_000);
}

#[test]
fn a_target_asked_before_the_start_plays_at_the_moment_asked() {
    // With compensation the lookahead is a jump's lead-in; without, the re-strike gap is.
    for compensation in [true, false] {
        a_target_plays_at_the_moment_asked(compensation);
    }
}

fn a_target_plays_at_the_moment_asked(compensation: bool) {
    let song = corpus_song("bach-invention-01.mid");
    let target = song.bar_start_us(5).unwrap();
    let control = Control::new();
    control.jump_to(target);
    control.start_at(WallTime::from_micros(1_000_000));
    let played = play_with(&control, compensation);
    assert_eq!(control.time_map().unwrap().wall(target), 1_000_000);
    if compensation {
        let (at, error) = first_sounded(&played);
        assert!(at >= 1_000_000 && error.abs() <= 1_000, "{at} {error}");
    } else {
        // Sent at its time: the first note after the target went at the moment asked.
        let first_sent = played.records.iter().filter_map(|r| r.sent_us()).min();
        assert_eq!(first_sent, Some(1_000_000));
    }
    let skipped = played
        .records
        .iter()
        .filter(|r| r.outcome == Outcome::Skipped)
        .count();
    let before = song
        .events()
        .iter()
        .filter(|e| e.time_us < target && e.bytes.note_on().is_some())
        .count();
    assert_eq!(skipped, before);
}

#[test]
fn a_moment_too_soon_is_taken_as_soon_as_the_robot_can() {
    let control = Control::new();
    control.start_at(WallTime::from_micros(1));
    let soon = play(&control);
    let asap = play(&Control::new());
    assert_eq!(first_sounded(&soon), first_sounded(&asap));
}
