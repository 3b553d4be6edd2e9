//! Guards the guard's timer bookkeeping: the kept next deadline, the early return of `tick`
//! before it, and the mask of keys whose timers run.
//!
//! Two interpreters take the same random stream. The one under test is ticked only at its
//! own `next_deadline()` (and fed bytes as they come), as a firmware main loop does. The
//! reference is ticked every millisecond with `tick_exhaustive_with`, which visits every key
//! and never returns early, and is ticked that way again right before each byte. With every
//! time and every guard limit a whole number of milliseconds (and no duty limit, whose cut
//! times are not), every deadline falls on a tick of the reference; so both must make the same
//! board writes at the same times, and report the same `NoteEvent`s at the same times, the
//! same counters and statistics.
//!
//! Also: the thesis's configuration as a constant ([`Thesis`]) plays like the same
//! configuration held in the interpreter.

mod common;

use common::{guard, musical_chunk};
use orch_core::{
    ChannelMask, Config, Counters, Duration, Instant, Interpreter, KeyPhase, NoteEvent, NotePool,
    OutOfRange, Overlap, Recording, Stats, Thesis,
};
use proptest::prelude::*;

type Robot = Interpreter<4, 61>;

/// What a run produced: board writes and note events, each with its time in µs, and the
/// statistics, counters and every key's phase at the end.
#[derive(Debug, Default, PartialEq)]
struct Run {
    writes: Vec<(u64, u8, u16)>,
    events: Vec<(u64, NoteEvent)>,
    stats: Stats,
    counters: Counters,
    phases: Vec<KeyPhase>,
}

impl Run {
    fn flush(&mut self, robot: &mut Robot, t: Instant) {
        let mut boards = Recording::<8>::new();
        robot.flush(&mut boards).expect("recording never fails");
        for w in boards.writes() {
            self.writes.push((t.as_micros(), w.board.index, w.outputs));
        }
    }
}

/// A configuration like `common::any_config` but with no duty limit and a re-strike gap of
/// at least 1 ms.
fn config() -> impl Strategy<Value = Config<4>> {
    (
        any::<bool>(),
        any::<bool>(),
        prop_oneof![3 => Just(0xFFFFu16), 1 => any::<u16>()],
        guard(),
        any::<bool>(),
    )
        .prop_map(|(drop, sustain, mask, mut guard, hold)| {
            guard.duty = None;
            // A zero gap rests 1 µs (see the guard): not on a millisecond.
            guard.restrike_gap = guard.restrike_gap.max(Duration::from_millis(1));
            Config {
                overlap: if hold {
                    Overlap::Hold
                } else {
                    Overlap::Restrike
                },
                out_of_range: if drop {
                    OutOfRange::Drop
                } else {
                    OutOfRange::Fold
                },
                sustain,
                channels: ChannelMask(mask),
                guard,
                ..Config::THESIS
            }
        })
}

/// Chunks of MIDI with the whole milliseconds before each: mostly short, sometimes past the
/// watchdog or the hold limit.
fn timed_chunks() -> impl Strategy<Value = Vec<(u64, Vec<u8>)>> {
    let gap = prop_oneof![3 => Just(0u64), 6 => 0u64..40, 3 => 0u64..400, 1 => 0u64..3_000];
    prop::collection::vec((gap, musical_chunk()), 0..80)
}

/// Where the streams begin, in whole ms: at zero, or a few seconds before the clock passes
/// a multiple of 2³⁰ µs (per-key ages are clamped) or 2³² µs (the low 32 bits of the clock,
/// as the keys keep their stamps, wrap).
fn start() -> impl Strategy<Value = u64> {
    let before = |us: u64| (us / 1000 - 4_000..us / 1000).prop_map(|ms| ms * 1000);
    prop_oneof![
        2 => Just(0u64),
        1 => before(1 << 30),
        1 => before(3 << 30),
        1 => before(1 << 32),
    ]
}

/// Ticks only at `next_deadline()`, as the firmware does, and checks what `feed` says.
fn run_at_deadlines(config: Config<4>, start: u64, chunks: &[(u64, Vec<u8>)], end: u64) -> Run {
    let mut robot = Robot::new(config).unwrap();
    let mut run = Run::default();
    let mut t = start;
    let mut ticks = 0;
    let mut until = |robot: &mut Robot, run: &mut Run, t: u64| {
        while let Some(d) = robot.next_deadline().filter(|d| d.as_micros() <= t) {
            let mut sink = |e| run.events.push((d.as_micros(), e));
            robot.tick_with(d, &mut sink);
            run.flush(robot, d);
            ticks += 1;
            assert!(
                ticks < 100_000,
                "next_deadline() makes no progress at {d:?}"
            );
        }
    };
    for (gap, bytes) in chunks {
        t += gap * 1000;
        until(&mut robot, &mut run, t);
        let now = Instant::from_micros(t);
        // Byte by byte: where `feed` says nothing changed, the frame and the deadline are as
        // they were (so the ATmega16 firmware skips its flush check and its deadline there).
        for &byte in bytes {
            let (frame, deadline) = (*robot.frame(), robot.next_deadline());
            let mut sink = |e| run.events.push((t, e));
            if !robot.feed_with(byte, now, &mut sink) {
                assert_eq!(
                    robot.frame(),
                    &frame,
                    "feed({byte:#04x}) said nothing changed"
                );
                assert_eq!(
                    robot.next_deadline(),
                    deadline,
                    "feed({byte:#04x}) said nothing changed"
                );
            }
        }
        run.flush(&mut robot, now);
    }
    until(&mut robot, &mut run, end);
    // The clock at the end too (key phases depend on it).
    let mut sink = |e| run.events.push((end, e));
    robot.tick_with(Instant::from_micros(end), &mut sink);
    run.flush(&mut robot, Instant::from_micros(end));
    finish(robot, run)
}

/// Ticks every millisecond the exhaustive way, and before every byte.
fn run_every_ms(config: Config<4>, start: u64, chunks: &[(u64, Vec<u8>)], end: u64) -> Run {
    let mut robot = Robot::new(config).unwrap();
    let mut run = Run::default();
    let mut clock = start;
    let mut until = |robot: &mut Robot, run: &mut Run, t: u64| {
        while clock <= t {
            let now = Instant::from_micros(clock);
            let mut sink = |e| run.events.push((clock, e));
            robot.tick_exhaustive_with(now, &mut sink);
            run.flush(robot, now);
            clock += 1000;
        }
    };
    let mut t = start;
    for (gap, bytes) in chunks {
        t += gap * 1000;
        until(&mut robot, &mut run, t);
        let now = Instant::from_micros(t);
        let mut sink = |e| run.events.push((t, e));
        // Each byte's own tick comes after the exhaustive tick at the same time: nothing left.
        robot.feed_slice_with(bytes, now, &mut sink);
        run.flush(&mut robot, now);
    }
    until(&mut robot, &mut run, end);
    finish(robot, run)
}

fn finish(robot: Robot, mut run: Run) -> Run {
    run.stats = *robot.stats();
    run.counters = robot.counters();
    run.phases = (0..61).map(|k| robot.key_phase(k)).collect();
    run
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn ticking_at_next_deadline_equals_ticking_every_millisecond(
        config in config(),
        start in start(),
        chunks in timed_chunks(),
    ) {
        let total: u64 = chunks.iter().map(|(gap, _)| gap * 1000).sum();
        // Past the longest limit (hold 400 ms, watchdog 5 s), so every timer has fired.
        let end = start + total + 6_000_000;
        let fast = run_at_deadlines(config, start, &chunks, end);
        let reference = run_every_ms(config, start, &chunks, end);
        prop_assert_eq!(&fast.events, &reference.events);
        prop_assert_eq!(&fast.writes, &reference.writes);
        prop_assert_eq!(fast, reference);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// The thesis's configuration as a constant type plays exactly like the same
    /// configuration held in the interpreter.
    #[test]
    fn the_fixed_thesis_configuration_plays_like_the_held_one(chunks in timed_chunks()) {
        let mut held = Interpreter::<4, 61, NotePool<32>>::thesis_with();
        let mut fixed = Interpreter::<4, 61, NotePool<32>, Thesis>::thesis_fixed();
        prop_assert_eq!(held.config(), fixed.config());
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let mut t = 0;
        for (gap, bytes) in &chunks {
            t += gap * 1000;
            let now = Instant::from_micros(t);
            while let Some(d) = held.next_deadline().filter(|&d| d <= now) {
                prop_assert_eq!(fixed.next_deadline(), Some(d));
                held.tick_with(d, &mut |e| a.push((d, e)));
                fixed.tick_with(d, &mut |e| b.push((d, e)));
                prop_assert_eq!(held.frame(), fixed.frame());
            }
            held.feed_slice_with(bytes, now, &mut |e| a.push((now, e)));
            fixed.feed_slice_with(bytes, now, &mut |e| b.push((now, e)));
            prop_assert_eq!(held.frame(), fixed.frame());
            prop_assert_eq!(held.next_deadline(), fixed.next_deadline());
        }
        prop_assert_eq!(a, b);
        prop_assert_eq!(held.stats(), fixed.stats());
    }
}
