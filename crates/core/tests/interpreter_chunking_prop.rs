//! Guards: the interpreter's output depends on the bytes and their times only, not on how
//! they were handed over. The same stream fed at once, in random chunks, or byte by byte (with
//! the same times) gives the same frames after every step, the same board writes, the same
//! stats, counters and deadlines.

mod common;

use common::{any_config, byte_stream, timed_steps, Rig};
use orch_core::Config;
use proptest::prelude::*;

/// Feeds `bytes` at `t` in pieces cut at `cuts` (some by `feed_slice`, some byte by byte).
fn feed_in_pieces(rig: &mut Rig, bytes: &[u8], cuts: &[usize], t: orch_core::Instant) {
    rig.run_until(t);
    let mut start = 0;
    let mut cuts: Vec<usize> = cuts.iter().map(|&c| c.min(bytes.len())).collect();
    cuts.sort_unstable();
    cuts.push(bytes.len());
    for (i, cut) in cuts.into_iter().enumerate() {
        let piece = &bytes[start..cut.max(start)];
        if i % 2 == 0 {
            rig.robot.feed_slice(piece, t);
        } else {
            for &b in piece {
                rig.robot.feed(b, t);
            }
        }
        start = cut.max(start);
    }
    rig.flush(t);
}

fn same(a: &Rig, b: &Rig) {
    assert_eq!(a.robot.frame(), b.robot.frame());
    assert_eq!(a.last, b.last);
    assert_eq!(a.timeline, b.timeline);
    assert_eq!(a.robot.stats(), b.robot.stats());
    assert_eq!(a.robot.counters(), b.robot.counters());
    assert_eq!(a.robot.next_deadline(), b.robot.next_deadline());
    assert_eq!(a.robot.keys_down(), b.robot.keys_down());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn chunks_at_the_same_times_give_the_same_frames(
        config in any_config(),
        steps in timed_steps(50),
        cuts in prop::collection::vec(prop::collection::vec(0usize..40, 0..4), 50),
    ) {
        let mut whole = Rig::new(config);
        let mut pieces = Rig::new(config);
        let mut t = 0;
        for (i, step) in steps.iter().enumerate() {
            t += step.gap;
            let now = common::us(t);
            match &step.bytes {
                Some(bytes) => {
                    whole.feed(bytes, now);
                    feed_in_pieces(&mut pieces, bytes, &cuts[i], now);
                }
                None => {
                    whole.run_until(now);
                    whole.tick(now);
                    pieces.run_until(now);
                    pieces.tick(now);
                }
            }
            same(&whole, &pieces);
        }
    }

    #[test]
    fn a_whole_stream_at_one_time_equals_it_fed_in_any_chunks(
        bytes in byte_stream(300),
        cuts in prop::collection::vec(0usize..300, 0..10),
    ) {
        let mut whole = Rig::new(Config::THESIS);
        whole.feed(&bytes, common::ms(5));
        let mut pieces = Rig::new(Config::THESIS);
        feed_in_pieces(&mut pieces, &bytes, &cuts, common::ms(5));
        same(&whole, &pieces);
        prop_assert_eq!(whole.robot.counters().bytes as usize, bytes.len());
    }
}
