//! Guards the 32-bit clock of the `*_low32` methods (for 8-bit MCUs): fed the low 32 bits of
//! the times, calls less than 2³⁰ µs apart, the interpreter does exactly what it does given
//! 64-bit instants: the same frames, the same answers from `feed` and `tick`, the same
//! deadlines (their low 32 bits), the same key phases, across wraps of the low 32 bits and
//! the multiples of 2³⁰ µs where the keys' ages are clamped.

mod common;

use common::{any_config, musical_chunk};
use orch_core::{Instant, Interpreter, KeyPhase, NotePool};
use proptest::prelude::*;

type Robot = Interpreter<4, 61, NotePool<32>>;

/// Gaps from none to just under 2³⁰ µs, the longest the `*_low32` methods allow.
fn gap() -> impl Strategy<Value = u64> {
    prop_oneof![
        3 => Just(0u64),
        4 => 0u64..2_000,
        4 => 0u64..120_000,
        1 => 0u64..6_000_000,
        1 => (1u64 << 29)..(1 << 30),
    ]
}

/// Clocks that start just before a wrap of 32 bits or a multiple of 2³⁰ µs, or anywhere.
fn start() -> impl Strategy<Value = u64> {
    prop_oneof![
        Just(0u64),
        ((1u64 << 32) - 3_000_000)..(1 << 32),
        ((1u64 << 30) - 3_000_000)..(1 << 30),
        ((5u64 << 32) - 70_000_000)..(5 << 32),
        any::<u32>().prop_map(u64::from),
    ]
}

fn same(wide: &Robot, narrow: &Robot, what: &str) {
    assert_eq!(wide.frame(), narrow.frame(), "{what}: frames");
    assert_eq!(
        wide.next_deadline().map(|d| d.as_micros() as u32),
        narrow.next_deadline_low32(),
        "{what}: deadlines"
    );
    assert_eq!(
        wide.next_deadline(),
        narrow.next_deadline(),
        "{what}: whole deadlines (the high bits followed the wraps)"
    );
    assert_eq!(wide.keys_down(), narrow.keys_down(), "{what}");
    for key in 0..61 {
        assert_eq!(
            wide.key_phase(key),
            narrow.key_phase(key),
            "{what}: key {key}"
        );
    }
}

/// A key released 2³² µs + 10 ms ago (its age's low 32 bits: 10 ms, inside the re-strike
/// gap) is up, not resting: the ages were clamped as the clock passed the multiples of 2³⁰ µs.
#[test]
fn a_key_released_one_wrap_ago_is_not_resting() {
    for start in [0u64, (1 << 30) - 7, (1 << 32) - 5_000_000] {
        let mut wide = Robot::thesis_with();
        let mut narrow = Robot::thesis_with();
        let mut t = 0;
        let mut tick_to = |wide: &mut Robot, narrow: &mut Robot, to: u64| {
            while t < to {
                t = (t + (1 << 30) - 1).min(to);
                wide.tick(Instant::from_micros(t));
                narrow.tick_low32(t as u32);
            }
        };
        tick_to(&mut wide, &mut narrow, start);
        for (b, at) in [
            (0x90, 0),
            (60, 0),
            (100, 0),
            (0x80, 50_000),
            (60, 50_000),
            (0, 50_000),
        ] {
            wide.feed(b, Instant::from_micros(start + at));
            narrow.feed_low32(b, (start + at) as u32);
        }
        assert_eq!(narrow.key_phase(24), KeyPhase::Resting);
        tick_to(&mut wide, &mut narrow, start + 50_000 + (1 << 32) + 10_000);
        same(&wide, &narrow, "after the silence");
        assert_eq!(narrow.key_phase(24), KeyPhase::Up, "from {start}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn the_low_32_bits_of_the_clock_play_like_64_bit_instants(
        config in any_config(),
        start in start(),
        steps in prop::collection::vec((gap(), prop::option::weighted(0.85, musical_chunk())), 0..40),
    ) {
        let mut wide = Robot::new(config).unwrap();
        let mut narrow = Robot::new(config).unwrap();
        // Both go from time zero to `start` by ticks less than 2³⁰ µs apart, as a firmware's
        // clock does from power-up.
        let mut t = 0;
        while t < start {
            t = (t + (1 << 29)).min(start);
            wide.tick(Instant::from_micros(t));
            narrow.tick_low32(t as u32);
        }
        for (i, (gap, bytes)) in steps.iter().enumerate() {
            t += gap;
            // The deadlines that fall before this step, each at its own time, as a firmware
            // runs them.
            while let Some(d) = wide.next_deadline().filter(|d| d.as_micros() <= t) {
                wide.tick(d);
                prop_assert!(narrow.tick_low32(d.as_micros() as u32), "step {i}: a deadline that ran nothing");
                same(&wide, &narrow, &format!("step {i}, the deadline at {}", d.as_micros()));
            }
            match bytes {
                Some(bytes) => {
                    for &b in bytes {
                        let a = wide.feed(b, Instant::from_micros(t));
                        let n = narrow.feed_low32(b, t as u32);
                        prop_assert_eq!(a, n, "step {}: byte {:#04x}", i, b);
                        same(&wide, &narrow, &format!("step {i}, byte {b:#04x}"));
                    }
                }
                None => {
                    wide.tick(Instant::from_micros(t));
                    narrow.tick_low32(t as u32);
                    same(&wide, &narrow, &format!("step {i}, a tick"));
                }
            }
        }
    }
}
