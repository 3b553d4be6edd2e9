//! Property tests of the planner and the account, on random scores over a few keys (dense
//! repeats, overlaps, unisons, folds, zero-length notes): the streaming plan equals the
//! whole-song plan; every note gets exactly one outcome and they add up; every strike finds
//! its sound; no strike sounds later than the late limit (plus the bus); every key is up at
//! the end.

use orch_core::{Config, Overlap};
use orch_perform::{
    thesis_config, Link, MidiRecording, Outcome, Performer, Planner, ScoreEvent, Setup, Tempo,
};
use orch_seq::WireBytes;
use proptest::prelude::*;

/// (time ms, channel, note, length ms) notes, made into score events in time order.
fn score(notes: &[(u16, u8, u8, u16)]) -> Vec<ScoreEvent> {
    let mut v = Vec::new();
    for &(t, ch, n, len) in notes {
        v.push((t as u64 * 1000, 1u8, [0x90 | ch, n, 100]));
        // A zero-length note's release comes after its own press.
        let class = if len == 0 { 2 } else { 0 };
        v.push(((t as u64 + len as u64) * 1000, class, [0x80 | ch, n, 0]));
    }
    // In time order; at one instant, releases of earlier notes before presses (as orch-seq
    // orders a song), then the releases of zero-length notes.
    v.sort_by_key(|e| (e.0, e.1));
    v.into_iter()
        .map(|(t, _, b)| ScoreEvent {
            score_us: t,
            bytes: WireBytes::new(&b),
        })
        .collect()
}

fn notes() -> impl Strategy<Value = Vec<(u16, u8, u8, u16)>> {
    // Few keys (60, 62, and 48/72 that fold onto 60 at 36..=96? no: 48 and 72 are in range;
    // 24 and 108 fold onto 36 and 96), two channels, times on a 5 ms grid.
    prop::collection::vec(
        (
            (0u16..400).prop_map(|t| t * 5),
            0u8..2,
            prop::sample::select(vec![60u8, 62, 24, 36, 108, 96]),
            prop_oneof![Just(0u16), 1u16..40, 40u16..400],
        ),
        1..60,
    )
}

mod common;

fn setup(overlap: Overlap, link: Link) -> Setup {
    let mut s = common::setup_with(
        Config {
            overlap,
            ..thesis_config()
        },
        link,
    );
    s.sim.keep = orch_sim::Keep::Presses;
    s
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn streaming_equals_whole_and_every_note_is_accounted_for(
        notes in notes(),
        hold in any::<bool>(),
        din in any::<bool>(),
    ) {
        let overlap = if hold { Overlap::Hold } else { Overlap::Restrike };
        let link = if din { Link::Din } else { Link::Direct };
        let s = setup(overlap, link);
        let events = score(&notes);
        let mut a = Planner::new(events.clone().into_iter(), s.rules(), 1_000, Tempo::NORMAL);
        let mut b = Planner::new(events.clone().into_iter(), s.rules(), 1_000, Tempo::NORMAL).eager();
        loop {
            let (x, y) = (a.next_planned(), b.next_planned());
            prop_assert_eq!(&x, &y);
            if x.is_none() {
                break;
            }
        }
        let mut out = MidiRecording::default();
        let mut performer = Performer::new(&s, events.into_iter(), notes.len());
        if din {
            performer = performer.midi(&mut out);
        }
        let played = performer.run().unwrap();
        let r = played.report(None);
        prop_assert!(r.adds_up(), "{:?}", r);
        prop_assert_eq!(r.notes, notes.len() as u64);
        prop_assert_eq!(r.unmatched, 0, "{:?}", played.records);
        prop_assert_eq!(r.outcomes.dropped.stopped, 0);
        // Late by at most the limit, plus the line's queue on DIN.
        let slack = if din { 10.0 } else { 0.5 };
        for rec in &played.records {
            if let Outcome::Late { by_us } = rec.outcome {
                prop_assert!(by_us as f64 / 1000.0 <= 30.0 + slack, "{:?}", rec);
            }
        }
        // Every key is up at the end.
        prop_assert_eq!(played.performance.summary.mechanics.stuck_at_end, 0);
    }
}
