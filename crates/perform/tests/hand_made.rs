//! Hand-made songs with known outcomes: each asserts the exact counts.

use orch_core::{Config, GuardConfig, Overlap};
use orch_perform::{thesis_config, Link, Outcome, Played, ScoreEvent, Setup};
use orch_seq::WireBytes;

/// (ms, bytes) → score events.
fn song(events: &[(u64, &[u8])]) -> (Vec<ScoreEvent>, usize) {
    let mut v: Vec<ScoreEvent> = events
        .iter()
        .map(|(ms, b)| ScoreEvent {
            score_us: ms * 1000,
            bytes: WireBytes::new(b),
        })
        .collect();
    v.sort_by_key(|e| e.score_us);
    let notes = v.iter().filter(|e| e.bytes.note_on().is_some()).count();
    (v, notes)
}

mod common;

fn setup(config: Config<16>) -> Setup {
    common::setup_with(config, Link::Direct)
}

fn play(setup: &Setup, events: &[(u64, &[u8])]) -> Played {
    let (events, notes) = song(events);
    common::render(setup, events.into_iter(), notes)
}

fn overlap(o: Overlap) -> Config<16> {
    Config {
        overlap: o,
        ..thesis_config()
    }
}

fn names(p: &Played) -> Vec<&'static str> {
    p.records.iter().map(|r| r.outcome.name()).collect()
}

#[test]
fn a_unison_on_two_channels_is_one_strike_and_one_unison() {
    for o in [Overlap::Hold, Overlap::Restrike] {
        let p = play(
            &setup(overlap(o)),
            &[
                (100, &[0x90, 60, 100]),
                (100, &[0x91, 60, 100]),
                (600, &[0x80, 60, 0]),
                (600, &[0x81, 60, 0]),
            ],
        );
        assert_eq!(names(&p), ["on_time", "unison"], "{o:?}");
        let r = p.report(None);
        assert_eq!((r.strikes, r.outcomes.unison), (1, 1));
        assert!(r.adds_up());
    }
}

#[test]
fn a_held_note_joined_by_another_joins_under_hold_and_restrikes_on_time_under_restrike() {
    let events: &[(u64, &[u8])] = &[
        (100, &[0x90, 60, 100]),
        (400, &[0x91, 60, 100]),
        (700, &[0x81, 60, 0]),
        (900, &[0x80, 60, 0]),
    ];
    let hold = play(&setup(overlap(Overlap::Hold)), events);
    assert_eq!(names(&hold), ["on_time", "joined"]);
    assert_eq!(hold.report(None).strikes, 1);
    // Restrike: the planner lets the key go 60 ms before the second note's press, so it
    // strikes again on time.
    let re = play(&setup(overlap(Overlap::Restrike)), events);
    assert_eq!(names(&re), ["on_time", "on_time"]);
    let r = re.report(None);
    assert_eq!((r.strikes, r.planning.early_releases_added), (2, 1));
    assert!(r.adds_up());
}

#[test]
fn a_repeat_at_40_ms_on_one_key_is_too_fast_under_both_settings() {
    // 40 ms between two strikes of one key: the key must rest 60 ms, so the second cannot
    // sound within 30 ms of its time; the first keeps its full length.
    for o in [Overlap::Hold, Overlap::Restrike] {
        let p = play(
            &setup(overlap(o)),
            &[
                (100, &[0x90, 60, 100]),
                (130, &[0x80, 60, 0]),
                (140, &[0x90, 60, 100]),
                (300, &[0x80, 60, 0]),
            ],
        );
        assert_eq!(names(&p), ["on_time", "too_fast"], "{o:?}");
        // With a 10 ms rest and no late limit, the re-strike lands on time in both.
        let mut c = overlap(o);
        c.guard.restrike_gap = orch_core::Duration::from_millis(10);
        let p = play(
            &setup(c),
            &[
                (100, &[0x90, 60, 100]),
                (130, &[0x80, 60, 0]),
                (140, &[0x90, 60, 100]),
                (300, &[0x80, 60, 0]),
            ],
        );
        assert_eq!(names(&p), ["on_time", "on_time"], "{o:?}");
    }
}

#[test]
fn a_repeat_with_no_note_off_between_re_strikes_under_restrike_and_joins_nothing() {
    // The same note twice on one channel, 200 ms apart, one Note-Off at the end.
    let events: &[(u64, &[u8])] = &[
        (100, &[0x90, 60, 100]),
        (300, &[0x90, 60, 100]),
        (600, &[0x80, 60, 0]),
    ];
    for o in [Overlap::Hold, Overlap::Restrike] {
        let p = play(&setup(overlap(o)), events);
        assert_eq!(names(&p), ["on_time", "on_time"], "{o:?}");
    }
}

#[test]
fn a_20_note_chord_against_a_budget_of_16_drops_4_for_power() {
    let mut ev: Vec<(u64, Vec<u8>)> = Vec::new();
    for i in 0..20u8 {
        ev.push((100, vec![0x90, 40 + i, 100]));
        ev.push((500, vec![0x80, 40 + i, 0]));
    }
    let ev: Vec<(u64, &[u8])> = ev.iter().map(|(t, b)| (*t, b.as_slice())).collect();
    let p = play(&setup(thesis_config()), &ev);
    let r = p.report(None);
    assert_eq!(r.outcomes.on_time, 16, "{r:?}");
    assert_eq!(r.outcomes.dropped.power, 4);
    assert_eq!(r.strikes, 16);
    assert_eq!(r.peak_keys_down, 16);
    assert!(r.adds_up());
}

#[test]
fn a_drum_roll_faster_than_the_key_can_repeat_never_falls_behind() {
    // 50 strikes 25 ms apart on one key (a roll at 40 Hz): the key can strike at most every
    // 60 ms + its shortest press, so most are dropped as too fast; none sounds later than
    // the late limit, and the last one is no later than the first.
    let mut ev: Vec<(u64, Vec<u8>)> = Vec::new();
    for i in 0..50u64 {
        ev.push((100 + i * 25, vec![0x90, 60, 100]));
        ev.push((110 + i * 25, vec![0x80, 60, 0]));
    }
    let ev: Vec<(u64, &[u8])> = ev.iter().map(|(t, b)| (*t, b.as_slice())).collect();
    let p = play(&setup(thesis_config()), &ev);
    let r = p.report(None);
    assert!(r.adds_up());
    assert_eq!(r.unmatched, 0);
    assert!(r.onset_ms.max <= 30.0, "{:?}", r.onset_ms);
    assert!(r.outcomes.on_time + r.outcomes.late >= 10, "{r:?}");
    assert!(r.outcomes.dropped.too_fast >= 25, "{r:?}");
    let late: Vec<f64> = p
        .records
        .iter()
        .filter_map(|r| match r.outcome {
            Outcome::Late { by_us } => Some(by_us as f64 / 1000.0),
            Outcome::OnTime { error_us } => Some(error_us as f64 / 1000.0),
            _ => None,
        })
        .collect();
    let (first, last) = (late[0], *late.last().unwrap());
    assert!(last <= first.max(1.0) + 30.0, "lateness piles up: {late:?}");
    assert!(late.iter().all(|&l| l <= 30.0), "{late:?}");
}

#[test]
fn a_guard_that_is_off_plays_the_bare_mapping_and_still_adds_up() {
    let c = Config {
        guard: GuardConfig::OFF,
        ..thesis_config()
    };
    let p = play(&setup(c), &[(100, &[0x90, 60, 100]), (200, &[0x80, 60, 0])]);
    assert_eq!(names(&p), ["on_time"]);
}

#[test]
fn a_key_struck_again_every_9_9_s_is_cut_by_the_duty_limit_and_the_report_says_so() {
    // Held 9.8 s, struck again 0.1 s later, for two minutes: never past the 10 s hold limit,
    // but powered 99 % of the time.
    let mut ev: Vec<(u64, Vec<u8>)> = Vec::new();
    for i in 0..12u64 {
        ev.push((100 + i * 9_900, vec![0x90, 60, 100]));
        ev.push((100 + i * 9_900 + 9_800, vec![0x80, 60, 0]));
    }
    let ev: Vec<(u64, &[u8])> = ev.iter().map(|(t, b)| (*t, b.as_slice())).collect();
    let r = play(&setup(thesis_config()), &ev).report(None);
    assert_eq!(r.cut_by_hold_limit, 0);
    assert!(r.cut_by_duty_limit >= 1, "{r:?}");
    assert!(r.adds_up());
    // Without the duty limit nothing cuts it.
    let mut c = thesis_config();
    c.guard.duty = None;
    let r = play(&setup(c), &ev).report(None);
    assert_eq!(r.cut_by_duty_limit, 0);
}
