//! Latency compensation and tempo scale.

mod common;

use std::collections::BTreeMap;

use orch_core::{ChannelMask, KeyRange, OutOfRange};
use orch_seq::{
    schedule, Compensation, Event, RunningStatus, Schedule, TempoScale, VirtualClock, WireBytes,
};
use proptest::prelude::*;

fn ev(time_us: u64, bytes: &[u8]) -> Event {
    Event {
        time_us,
        tick: time_us,
        track: 0,
        bytes: WireBytes::new(bytes),
    }
}

/// Notes as (key 0..keys, start µs, length µs) → events in playing order (offs first at a tie).
fn events_of(notes: &[(u8, u64, u64)]) -> Vec<Event> {
    let mut list: Vec<(u64, u8, Vec<u8>)> = Vec::new();
    for &(key, start, len) in notes {
        list.push((start, 1, vec![0x90, 60 + key, 100]));
        list.push((start + len, 0, vec![0x80, 60 + key, 0]));
    }
    list.sort_by_key(|(t, kind, _)| (*t, *kind));
    list.into_iter().map(|(t, _, b)| ev(t, &b)).collect()
}

fn key_of(_channel: u8, note: u8) -> Option<u16> {
    Some(u16::from(note))
}

/// Per key, the entries in sending order.
fn per_key(s: &Schedule) -> BTreeMap<u16, Vec<&orch_seq::Scheduled>> {
    let mut map: BTreeMap<u16, Vec<_>> = BTreeMap::new();
    for e in s.entries() {
        if let Some(k) = e.key {
            map.entry(k).or_default().push(e);
        }
    }
    map
}

#[test]
fn note_on_is_sent_early_by_press_delay_and_note_off_by_release_delay() {
    let events = events_of(&[(0, 100_000, 200_000), (1, 150_000, 100_000)]);
    let comp = Compensation::uniform(key_of, 30_000, 12_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    assert_eq!(s.lead_in_us(), 0);
    for e in s.entries() {
        let delay = if e.bytes.note_on().is_some() {
            30_000
        } else {
            12_000
        };
        assert_eq!(e.send_us, e.score_us - delay, "{e:?}");
    }
    let sends: Vec<u64> = s.entries().iter().map(|e| e.send_us).collect();
    assert_eq!(sends, [70_000, 120_000, 238_000, 288_000]);
    assert_eq!(s.stats(), Default::default());
}

#[test]
fn per_key_delays_are_used() {
    let events = events_of(&[(0, 100_000, 50_000), (5, 100_000, 50_000)]);
    let comp = Compensation::new(key_of, |k| u64::from(k) * 1000, |k| u64::from(k) * 100);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    for e in s.entries() {
        let k = u64::from(e.key.unwrap());
        let d = if e.bytes.note_on().is_some() {
            k * 1000
        } else {
            k * 100
        };
        assert_eq!(e.send_us, e.score_us - d);
    }
}

#[test]
fn first_send_before_zero_shifts_everything_and_reports_lead_in() {
    let events = events_of(&[(0, 0, 100_000)]);
    let comp = Compensation::uniform(key_of, 40_000, 10_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    assert_eq!(s.lead_in_us(), 40_000);
    assert_eq!(s.entries()[0].send_us, 0);
    assert_eq!(s.entries()[0].score_us, 40_000);
    assert_eq!(s.entries()[1].send_us, 130_000);
}

#[test]
fn compensation_off_sends_at_score_times() {
    let events = events_of(&[(0, 0, 100_000), (0, 100_000, 100_000), (1, 30_000, 5_000)]);
    let off = Compensation::uniform(key_of, 40_000, 10_000)
        .restrike_gap_us(60_000)
        .enabled(false);
    assert!(!off.is_enabled());
    for s in [
        schedule(&events, TempoScale::NORMAL, Some(&off)),
        schedule(&events, TempoScale::NORMAL, None),
    ] {
        assert_eq!(s.lead_in_us(), 0);
        let got: Vec<(u64, Vec<u8>)> = s
            .entries()
            .iter()
            .map(|e| (e.send_us, e.bytes.to_vec()))
            .collect();
        let want: Vec<(u64, Vec<u8>)> = events
            .iter()
            .map(|e| (e.time_us, e.bytes.to_vec()))
            .collect();
        assert_eq!(got, want);
        assert!(s
            .entries()
            .iter()
            .all(|e| e.send_us == e.score_us && e.key.is_none()));
    }
}

#[test]
fn tempo_scale_2_halves_and_0_5_doubles_times() {
    let events = events_of(&[(0, 100_000, 300_000)]);
    let fast = schedule(&events, TempoScale::new(2.0).unwrap(), None);
    let slow = schedule(&events, TempoScale::new(0.5).unwrap(), None);
    let t = |s: &Schedule| s.entries().iter().map(|e| e.send_us).collect::<Vec<_>>();
    assert_eq!(t(&fast), [50_000, 200_000]);
    assert_eq!(t(&slow), [200_000, 800_000]);
    // Delays are physical: not scaled.
    let comp = Compensation::uniform(key_of, 10_000, 10_000);
    let fast = schedule(&events, TempoScale::new(2.0).unwrap(), Some(&comp));
    assert_eq!(t(&fast), [40_000, 190_000]);
}

#[test]
fn restrike_gap_moves_the_release_earlier_when_it_can() {
    // Repeated note: off and on both at 500 ms. P = 20 ms, R = 10 ms, gap 60 ms.
    let events = events_of(&[(0, 0, 500_000), (0, 500_000, 500_000)]);
    let comp = Compensation::uniform(key_of, 20_000, 10_000).restrike_gap_us(60_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    let lead = s.lead_in_us();
    let sends: Vec<i64> = s
        .entries()
        .iter()
        .map(|e| e.send_us as i64 - lead as i64)
        .collect();
    // The press goes at 480 ms as compensation wants; the release moves to 420 ms.
    assert_eq!(sends, [-20_000, 420_000, 480_000, 990_000]);
    assert_eq!(s.stats().releases_moved_early, 1);
    assert_eq!(s.stats().presses_delayed, 0);
}

#[test]
fn restrike_gap_delays_the_press_when_the_release_cannot_move() {
    // A 30 ms note then the same key again: the release cannot move before its own press +
    // min_press (20 ms), so the next press waits for release + gap.
    let events = events_of(&[(0, 100_000, 30_000), (0, 130_000, 100_000)]);
    let comp = Compensation::uniform(key_of, 0, 0)
        .restrike_gap_us(60_000)
        .min_press_us(20_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    let sends: Vec<u64> = s.entries().iter().map(|e| e.send_us).collect();
    assert_eq!(sends, [100_000, 120_000, 180_000, 230_000]);
    assert_eq!(s.stats().releases_moved_early, 1);
    assert_eq!(s.stats().presses_delayed, 1);
    assert_eq!(s.stats().max_press_delay_us, 50_000);
}

#[test]
fn short_note_is_not_swallowed_by_a_longer_release_delay() {
    // 5 ms note, P = 10 ms, R = 30 ms: the release would come before the press.
    let events = events_of(&[(0, 100_000, 5_000)]);
    let comp = Compensation::uniform(key_of, 10_000, 30_000).min_press_us(20_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    let sends: Vec<u64> = s.entries().iter().map(|e| e.send_us).collect();
    assert_eq!(sends, [90_000, 95_000]); // held for the score's own 5 ms
    assert!(s.entries()[0].bytes.note_on().is_some());
}

#[test]
fn unmapped_notes_and_other_messages_go_at_score_time() {
    let events = vec![
        ev(100_000, &[0x90, 20, 100]),
        ev(100_000, &[0xC0, 3]),
        ev(150_000, &[0x80, 20, 0]),
    ];
    let comp = Compensation::uniform(|_, n| (n >= 36).then_some(u16::from(n)), 30_000, 30_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    assert!(s
        .entries()
        .iter()
        .all(|e| e.send_us == e.score_us && e.key.is_none()));
}

#[test]
fn core_key_map_folds_like_the_interpreter_and_masks_channels() {
    let map = Compensation::core_key_map(
        KeyRange::THESIS,
        OutOfRange::Fold,
        ChannelMask::NONE.with(orch_core::Channel::new(0).unwrap()),
    );
    assert_eq!(map(0, 36), Some(0));
    assert_eq!(map(0, 24), Some(0));
    assert_eq!(map(0, 97), Some(49));
    assert_eq!(map(1, 60), None);
}

#[test]
fn schedule_plays_on_a_virtual_clock_in_send_order() {
    let events = events_of(&[(0, 0, 100_000), (1, 50_000, 100_000)]);
    let comp = Compensation::uniform(key_of, 20_000, 20_000);
    let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
    let mut clock = VirtualClock::new();
    let mut sent = Vec::new();
    let lateness = s.play(&mut clock, RunningStatus::On, |t, b| {
        sent.push((t, b.to_vec()))
    });
    assert_eq!(lateness.max_us, 0);
    assert_eq!(
        sent,
        [
            (0, vec![0x90, 60, 100]),
            (50_000, vec![61, 100]),
            (100_000, vec![0x80, 60, 0]),
            (150_000, vec![61, 0])
        ]
    );
}

fn notes_strategy() -> impl Strategy<Value = Vec<(u8, u64, u64)>> {
    proptest::collection::vec((0u8..4, 0u64..2_000_000, 1u64..300_000), 0..60)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn per_key_send_order_equals_score_order(
        notes in notes_strategy(),
        p in 0u64..80_000, r in 0u64..80_000, gap in 0u64..100_000, min in 0u64..30_000,
    ) {
        let events = events_of(&notes);
        let comp = Compensation::new(key_of, move |k| p + u64::from(k) * 3_000, move |k| r + u64::from(k) * 7_000)
            .restrike_gap_us(gap).min_press_us(min);
        let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
        prop_assert_eq!(s.entries().len(), events.len());
        prop_assert!(s.entries().windows(2).all(|w| w[0].send_us <= w[1].send_us));
        for (_, list) in per_key(&s) {
            let order: Vec<usize> = list.iter().map(|e| e.event).collect();
            let mut sorted = order.clone();
            sorted.sort_unstable();
            prop_assert_eq!(order, sorted);
        }
    }

    #[test]
    fn restrike_gap_is_never_broken(
        notes in notes_strategy(),
        p in 0u64..80_000, r in 0u64..80_000, gap in 0u64..100_000, min in 0u64..30_000,
    ) {
        let events = events_of(&notes);
        let comp = Compensation::new(key_of, move |k| p + u64::from(k) * 5_000, move |_| r)
            .restrike_gap_us(gap).min_press_us(min);
        let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
        for (_, list) in per_key(&s) {
            for w in list.windows(2) {
                if w[0].bytes.note_off().is_some() && w[1].bytes.note_on().is_some() {
                    prop_assert!(w[1].send_us - w[0].send_us >= gap, "{:?} then {:?}", w[0], w[1]);
                }
            }
        }
    }

    #[test]
    fn with_equal_delays_and_no_gap_every_message_is_sent_exactly_early(
        notes in notes_strategy(), d in 0u64..100_000,
    ) {
        let events = events_of(&notes);
        let comp = Compensation::uniform(key_of, d, d);
        let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
        for e in s.entries() {
            prop_assert_eq!(e.send_us + d, e.score_us);
            prop_assert_eq!(e.score_us, events[e.event].time_us + s.lead_in_us());
        }
    }

    #[test]
    fn tempo_scale_divides_score_times(notes in notes_strategy(), scale in 0.25f64..4.0) {
        let events = events_of(&notes);
        let s = schedule(&events, TempoScale::new(scale).unwrap(), None);
        for e in s.entries() {
            let want = (events[e.event].time_us as f64 / scale).round() as u64;
            prop_assert_eq!(e.score_us, want);
            prop_assert_eq!(e.send_us, want);
        }
    }
}
