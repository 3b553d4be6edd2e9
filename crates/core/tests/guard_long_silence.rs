//! Guards the guard across silences longer than 32 bits of microseconds.
//!
//! The interpreter keeps its deadlines and the time of the last input in 32 bits (the low bits
//! of the caller's clock, compared by wrapping difference), which is exact while they lie
//! within 2³¹ µs (35 minutes) of the clock. A caller that does not call for longer (a host
//! asleep, a process stopped) must still find every rule fired at its next call, as with
//! 64-bit instants: the watchdog, the hold limit and a waiting re-strike. Each case below is
//! run for silences around 2³¹, 2³² and beyond, from clocks that start anywhere, on both sides
//! of a multiple of 2³⁰ and 2³² µs.

mod common;

use common::{ms, us, Rig};
use orch_core::{GuardConfig, Instant, KeyPhase, NoteEvent};

/// Silences of 2³¹ − 1 µs and more: around the reach of 32-bit wrapping arithmetic.
const SILENCES: [u64; 10] = [
    (1 << 31) - 1,
    1 << 31,
    (1 << 31) + 1_000_000,
    (1 << 32) - 1,
    1 << 32,
    (1 << 32) + 1_000,
    (1 << 32) + 5_000_000,
    (1 << 32) + (1 << 31),
    (1 << 33) + 17,
    5 << 32,
];

/// Clocks that start at zero, just before a multiple of 2³⁰ or 2³² µs, or anywhere.
const STARTS: [u64; 5] = [
    0,
    (1 << 30) - 1_500,
    (1 << 32) - 3_000_000,
    123_456_789,
    (7 << 32) - 1,
];

fn at(start: u64, t: Instant) -> Instant {
    us(start + t.as_micros())
}

/// Runs `case` for every start and every silence.
fn every_start_and_silence(mut case: impl FnMut(u64, u64)) {
    for start in STARTS {
        for silence in SILENCES {
            case(start, silence);
        }
    }
}

/// The default guard without its watchdog: only the hold limit and the rest act.
const NO_WATCHDOG: GuardConfig = GuardConfig {
    watchdog: None,
    ..GuardConfig::DEFAULT
};

#[test]
fn the_watchdog_fires_after_a_silence_of_any_length() {
    every_start_and_silence(|start, silence| {
        let mut rig = Rig::thesis();
        rig.feed(&[0x90, 60, 100], at(start, ms(0)));
        assert!(rig.note_down(60));
        // No call at all for the whole silence, then one byte (not a note).
        let back = at(start, us(silence));
        rig.robot.feed(0xF8, back);
        rig.flush(back);
        assert!(
            !rig.note_down(60),
            "start {start}, silence {silence}: the watchdog let the key go"
        );
        assert_eq!(rig.robot.stats().cut_by_watchdog, 1, "{start} {silence}");
        assert_eq!(rig.edges_of(60).last(), Some(&(back, false)));
    });
}

#[test]
fn the_hold_limit_fires_after_a_silence_of_any_length() {
    every_start_and_silence(|start, silence| {
        // No watchdog: only the hold limit can let the key go.
        let mut rig = Rig::with_guard(NO_WATCHDOG);
        rig.feed(&[0x90, 60, 100], at(start, ms(0)));
        let back = at(start, us(silence));
        rig.tick(back);
        assert!(
            !rig.note_down(60),
            "start {start}, silence {silence}: the hold limit let the key go"
        );
        assert_eq!(rig.robot.stats().cut_by_hold_limit, 1, "{start} {silence}");
        assert_eq!(rig.robot.next_deadline(), None, "nothing left to do");
    });
}

#[test]
fn a_waiting_restrike_strikes_at_the_first_call_after_a_silence_of_any_length() {
    every_start_and_silence(|start, silence| {
        let mut rig = Rig::with_guard(NO_WATCHDOG);
        // Struck, released, struck again 40 ms later: it waits 20 ms for the 60 ms rest.
        rig.feed(&[0x90, 60, 100], at(start, ms(0)));
        rig.feed(&[0x80, 60, 0], at(start, ms(30)));
        rig.feed(&[0x90, 60, 100], at(start, ms(70)));
        assert_eq!(rig.robot.key_phase(24), KeyPhase::Waiting);
        let mut events = Vec::new();
        let back = at(start, us(silence));
        rig.robot.tick_with(back, &mut |e| events.push(e));
        assert!(
            events.contains(&NoteEvent::WaitOver { key: 24 }),
            "start {start}, silence {silence}: {events:?}"
        );
        // It strikes now and is cut by its hold limit 10 s later, not 35 minutes later.
        assert_eq!(rig.robot.key_phase(24), KeyPhase::Down);
        let limit = GuardConfig::DEFAULT.max_hold.unwrap();
        assert_eq!(
            rig.robot.next_deadline(),
            Some(Instant::from_micros(
                back.as_micros() + limit.as_micros() as u64
            ))
        );
    });
}

#[test]
fn next_deadline_reports_exact_instants_across_the_32_bit_wrap() {
    // The kept deadlines are 32-bit; what `next_deadline` says is the full instant.
    for start in STARTS {
        let mut rig = Rig::thesis();
        rig.feed(&[0x90, 60, 100], at(start, ms(0)));
        let watchdog = GuardConfig::DEFAULT.watchdog.unwrap();
        assert_eq!(
            rig.robot.next_deadline(),
            Some(at(start, us(watchdog.as_micros() as u64)))
        );
        rig.run_until(at(start, ms(60_000)));
        assert_eq!(rig.robot.next_deadline(), None);
        assert_eq!(
            rig.edges_of(60),
            vec![
                (at(start, ms(0)), true),
                (at(start, us(watchdog.as_micros() as u64)), false)
            ]
        );
    }
}

#[test]
fn a_restrike_long_after_its_release_does_not_wait() {
    // The rest is measured from the release; a key released an hour ago has rested.
    every_start_and_silence(|start, silence| {
        let mut rig = Rig::thesis();
        rig.feed(&[0x90, 60, 100], at(start, ms(0)));
        rig.feed(&[0x80, 60, 0], at(start, ms(100)));
        let back = at(start, us(silence));
        rig.robot.feed_slice(&[0x90, 60, 100], back);
        rig.flush(back);
        assert!(rig.note_down(60), "start {start}, silence {silence}");
        assert_eq!(rig.edges_of(60).last(), Some(&(back, true)));
    });
}
