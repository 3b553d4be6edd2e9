//! Strike groups: a drum kit beside a keyboard, a drum kit alone. A strike's pulse ends by
//! itself whatever the Note-Off does; a beater never strikes again within its rebound; a note
//! the kit lacks, or a drum note a keyboard leaves alone, is dropped with its own reason; the
//! watchdog and `all_off` end every pulse. Rules worked by hand first, then properties over any
//! byte stream.

mod common;

use common::{ms, Edge, Rig};
use orch_core::{
    ChannelMask, Config, DropReason, Duration, GuardConfig, Instant, KeyRange, Layout, Note,
    NoteEvent, OutOfRange, Pulse, Strikes,
};
use proptest::prelude::*;

/// Channel 10 (0-based 9), General MIDI's percussion.
const DRUMS: u8 = 9;

/// A GM kit's ten outputs, as `orch config --instrument drums` maps them.
const KIT: [&[u8]; 10] = [
    &[35, 36],     // kick
    &[37, 38, 40], // snare (side stick too)
    &[42],         // closed hi-hat
    &[44],         // pedal hi-hat
    &[46],         // open hi-hat
    &[41, 43],     // floor tom
    &[45, 47],     // mid tom
    &[48, 50],     // high tom
    &[49, 57],     // crash
    &[51, 59],     // ride
];

/// A keyboard of `keyboard` keys from C2 (on every channel but 10) and the kit on channel 10,
/// its outputs after the keyboard's keys, on four boards.
fn mixed(keyboard: u8, pulse: Pulse) -> Config<4> {
    let range = KeyRange::new(Note::from_bits(36), Note::from_bits(35 + keyboard)).unwrap();
    let mut strikes = Strikes::NONE;
    let outputs: Vec<(&[u8], Pulse)> = KIT.iter().map(|n| (*n, pulse)).collect();
    strikes
        .push_kit(ChannelMask(1 << DRUMS), range.keys(), &outputs)
        .unwrap();
    Config {
        channels: ChannelMask(!(1 << DRUMS)),
        range,
        layout: Layout::sequential([0x21, 0x22, 0x23, 0x24], range.keys() + KIT.len()),
        strikes,
        ..Config::THESIS
    }
}

/// The kit alone, outputs from key 0 (board 0).
fn kit_alone(pulse: Pulse) -> Config<4> {
    let mut strikes = Strikes {
        keyboard: false,
        ..Strikes::NONE
    };
    let outputs: Vec<(&[u8], Pulse)> = KIT.iter().map(|n| (*n, pulse)).collect();
    strikes
        .push_kit(ChannelMask(1 << DRUMS), 0, &outputs)
        .unwrap();
    Config {
        layout: Layout::sequential([0x21, 0x22, 0x23, 0x24], KIT.len()),
        strikes,
        ..Config::THESIS
    }
}

/// The kit's output `i` (0 = kick) on the boards of [`kit_alone`]: board 0, bit `i`.
fn edges(rig: &Rig, board: u8, bit: u8) -> Vec<(u64, bool)> {
    rig.timeline
        .iter()
        .filter(|e| e.board == board && e.bit == bit)
        .map(|e| (e.t.as_micros(), e.on))
        .collect()
}

fn hit(note: u8, velocity: u8) -> [u8; 3] {
    [0x90 | DRUMS, note, velocity]
}

#[test]
fn a_strikes_pulse_ends_by_itself_at_its_velocitys_length_whatever_the_note_off() {
    let mut rig = Rig::new(kit_alone(Pulse::DRUM));
    // Loud, with no Note-Off at all: 20 ms.
    rig.feed(&hit(36, 127), ms(0));
    // Soft, its Note-Off 1 ms later: still 8 ms.
    rig.feed(&hit(38, 1), ms(100));
    rig.feed(&[0x80 | DRUMS, 38, 0], ms(101));
    // Its Note-Off long after: nothing more happens.
    rig.feed(&[0x80 | DRUMS, 36, 0], ms(500));
    rig.run_until(ms(10_000));
    assert_eq!(edges(&rig, 0, 0), [(0, true), (20_000, false)]);
    assert_eq!(edges(&rig, 0, 1), [(100_000, true), (108_000, false)]);
    assert_eq!(rig.robot.keys_down(), 0);
}

#[test]
fn two_notes_of_one_beater_at_once_strike_once_and_the_second_joins() {
    let mut rig = Rig::new(kit_alone(Pulse::DRUM));
    let mut events = Vec::new();
    rig.robot
        .feed_slice_with(&[0x99, 35, 100, 36, 100], ms(0), &mut |e| events.push(e));
    rig.flush(ms(0));
    assert!(matches!(events[0], NoteEvent::Struck { .. }), "{events:?}");
    assert!(
        matches!(
            events[1],
            NoteEvent::Joined {
                with_strike: true,
                ..
            }
        ),
        "{events:?}"
    );
    rig.run_until(ms(1_000));
    assert_eq!(edges(&rig, 0, 0).len(), 2, "one strike");
}

#[test]
fn a_roll_faster_than_the_rebound_keeps_the_rebound() {
    // A snare roll every 15 ms at mixed velocities; the rebound is 40 ms.
    let pulse = Pulse::DRUM;
    let mut rig = Rig::new(Config {
        guard: GuardConfig {
            late_limit: Some(Duration::from_millis(30)),
            ..GuardConfig::DEFAULT
        },
        ..kit_alone(pulse)
    });
    let mut events = Vec::new();
    for i in 0..40u64 {
        let t = ms(i * 15);
        rig.run_until(t);
        rig.robot
            .feed_slice_with(&hit(38, 1 + (i * 37 % 127) as u8), t, &mut |e| {
                events.push(e)
            });
        rig.flush(t);
    }
    rig.run_until(ms(5_000));
    let strikes: Vec<u64> = edges(&rig, 0, 1)
        .iter()
        .filter(|e| e.1)
        .map(|e| e.0)
        .collect();
    assert!(strikes.len() >= 10, "{strikes:?}");
    for w in strikes.windows(2) {
        assert!(
            w[1] - w[0] >= pulse.rebound.as_micros() as u64,
            "two strikes {} µs apart: {strikes:?}",
            w[1] - w[0]
        );
    }
    // Never longer than the loud pulse.
    for pair in edges(&rig, 0, 1).chunks(2) {
        assert!(pair[1].0 - pair[0].0 <= pulse.loud.as_micros() as u64);
    }
    // Every note has one first event; those that strike are fewer than the notes: the rest
    // joined a strike (its pulse on, or waiting for the rebound) or were too fast.
    let first = |e: &&NoteEvent| {
        matches!(
            e,
            NoteEvent::Struck { .. }
                | NoteEvent::Waiting { .. }
                | NoteEvent::Leading { .. }
                | NoteEvent::Joined { .. }
                | NoteEvent::Dropped { .. }
        )
    };
    assert_eq!(events.iter().filter(first).count(), 40);
    let joined = events
        .iter()
        .filter(|e| matches!(e, NoteEvent::Joined { .. }))
        .count();
    assert_eq!(strikes.len() + joined, 40, "{events:?}");
}

#[test]
fn drum_notes_a_keyboard_leaves_alone_and_notes_the_kit_lacks_have_their_own_reasons() {
    // A keyboard on every channel but 10, no kit: drum notes are percussion.
    let piano = Config {
        channels: ChannelMask(!(1 << DRUMS)),
        ..Config::THESIS
    };
    let mut rig = Rig::new(piano);
    rig.feed(&hit(42, 100), ms(0));
    rig.feed(&[0x9A, 42, 100], ms(1)); // channel 11 is played
    let s = rig.robot.stats();
    assert_eq!(
        (s.dropped_percussion, s.dropped_channel, s.played),
        (1, 0, 1)
    );
    // The mixed robot: the kit plays 42, lacks 81 (open triangle).
    let mut rig = Rig::new(mixed(49, Pulse::DRUM));
    let mut events = Vec::new();
    rig.robot
        .feed_slice_with(&[0x99, 42, 100, 81, 100], ms(0), &mut |e| events.push(e));
    assert!(matches!(events[0], NoteEvent::Struck { at, .. } if at.key == 49 + 2));
    assert!(matches!(
        events[1],
        NoteEvent::Dropped {
            reason: DropReason::Unmapped,
            at: None,
            ..
        }
    ));
    assert_eq!(rig.robot.stats().dropped_unmapped, 1);
    // The keyboard still plays its notes, held as long as they sound.
    rig.feed(&[0x90, 60, 100], ms(10));
    rig.run_until(ms(2_000));
    assert!(rig.robot.is_down(24));
}

#[test]
fn all_off_and_the_watchdog_end_every_pulse_at_once() {
    let long = Pulse {
        soft: Duration::from_millis(90),
        loud: Duration::from_millis(100),
        rebound: Duration::from_millis(150),
    };
    let mut rig = Rig::new(kit_alone(long));
    rig.feed(&[0x99, 36, 100, 38, 100, 42, 100], ms(0));
    assert_eq!(rig.fingers_down(), 3);
    rig.all_off(ms(5));
    assert_eq!(rig.last, [0; 4]);
    // The watchdog: no byte for its 4 s while a pulse is on. A pulse that long needs a
    // watchdog shorter than it to matter: 50 ms.
    let mut rig = Rig::new(Config {
        guard: GuardConfig {
            watchdog: Some(Duration::from_millis(50)),
            ..GuardConfig::DEFAULT
        },
        ..kit_alone(long)
    });
    rig.feed(&hit(36, 127), ms(0));
    rig.run_until(ms(1_000));
    assert_eq!(edges(&rig, 0, 0), [(0, true), (50_000, false)]);
}

#[test]
fn the_power_budget_counts_pulses_while_they_are_on() {
    let mut rig = Rig::new(Config {
        guard: GuardConfig {
            max_keys_down: 2,
            ..GuardConfig::DEFAULT
        },
        ..kit_alone(Pulse::DRUM)
    });
    rig.feed(&[0x99, 36, 100, 38, 100, 42, 100], ms(0));
    assert_eq!(rig.robot.stats().dropped_power, 1);
    // Once the pulses are over the budget is free again.
    rig.feed(&hit(42, 100), ms(30));
    assert_eq!(rig.fingers_down(), 1);
}

#[test]
fn a_pulse_longer_than_the_guards_maximum_is_refused() {
    let long = Pulse {
        soft: Duration::from_millis(10),
        loud: Duration::from_millis(120),
        rebound: Duration::from_millis(200),
    };
    let err = orch_core::Interpreter::<4, 61>::new(kit_alone(long)).unwrap_err();
    assert!(err.to_string().contains("max_pulse"), "{err}");
    // A longer maximum lets it through.
    let config = Config {
        guard: GuardConfig {
            max_pulse: Duration::from_millis(120),
            ..GuardConfig::DEFAULT
        },
        ..kit_alone(long)
    };
    assert!(orch_core::Interpreter::<4, 61>::new(config).is_ok());
}

/// A stream for a piano-and-drums robot: notes on channel 1 and channel 10 (drum notes and
/// others), Note-Offs, running status, pedal and All Notes Off, real-time bytes, resets.
fn band_chunk() -> impl Strategy<Value = Vec<u8>> {
    let channel = prop_oneof![2 => Just(0u8), 3 => Just(DRUMS), 1 => 0u8..16];
    let note = prop_oneof![4 => 35u8..60, 2 => 30u8..100, 1 => 0u8..128];
    prop_oneof![
        6 => (channel.clone(), note.clone(), 0u8..128).prop_map(|(c, n, v)| vec![0x90 | c, n, v]),
        3 => (channel.clone(), note.clone()).prop_map(|(c, n)| vec![0x80 | c, n, 64]),
        2 => (note, 1u8..128).prop_map(|(n, v)| vec![n, v]),
        1 => (channel, prop::sample::select(vec![64u8, 120, 123])).prop_map(|(c, k)| vec![0xB0 | c, k, 127]),
        1 => prop::sample::select(vec![0xF8u8, 0xFE, 0xFF]).prop_map(|b| vec![b]),
    ]
}

fn band_steps() -> impl Strategy<Value = Vec<common::Step>> {
    let gap =
        prop_oneof![3 => Just(0u64), 4 => 0u64..30_000, 2 => 0u64..200_000, 1 => 0u64..5_000_000];
    prop::collection::vec(
        (gap, prop::option::weighted(0.9, band_chunk()))
            .prop_map(|(gap, bytes)| common::Step { gap, bytes }),
        0..80,
    )
}

fn pulse() -> impl Strategy<Value = Pulse> {
    (1u32..30, 0u32..70, 0u32..100).prop_map(|(soft, more, rest)| Pulse {
        soft: Duration::from_millis(soft),
        loud: Duration::from_millis(soft + more),
        rebound: Duration::from_millis(soft + more + rest),
    })
}

/// Every strike output's pulse ended within `max` and started no sooner than `rebound` after
/// its last one; keys of the keyboard are not checked here.
fn assert_strikes_kept(timeline: &[Edge], first_key: u8, pulse: Pulse, end: Instant) {
    let key_of = |e: &Edge| e.board * 16 + e.bit;
    let (max, rebound) = (
        pulse.loud.as_micros() as u64,
        pulse.rebound.as_micros() as u64,
    );
    let mut on: std::collections::HashMap<u8, u64> = Default::default();
    let mut last: std::collections::HashMap<u8, u64> = Default::default();
    for e in timeline.iter().filter(|e| key_of(e) >= first_key) {
        let (key, t) = (key_of(e), e.t.as_micros());
        if e.on {
            if let Some(prev) = last.insert(key, t) {
                assert!(t - prev >= rebound, "key {key}: strikes {prev} and {t} µs");
            }
            on.insert(key, t);
        } else {
            let t0 = on.remove(&key).expect("an up edge follows a down edge");
            assert!(t - t0 <= max, "key {key}: pulse {} µs > {max}", t - t0);
        }
    }
    for (key, t0) in on {
        assert!(end.as_micros() - t0 <= max, "key {key} still on at the end");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Whatever bytes come, whenever: every pulse ends within its loud length, two strikes of
    /// one beater are never closer than its rebound, and all_off leaves every output off.
    #[test]
    fn every_pulse_ends_and_every_rebound_holds_whatever_bytes_come(
        steps in band_steps(),
        pulse in pulse(),
        keyboard in 12u8..=51,
        alone in any::<bool>(),
    ) {
        let config = if alone { kit_alone(pulse) } else { mixed(keyboard, pulse) };
        let config = Config {
            guard: GuardConfig { max_pulse: Duration::from_millis(100), ..GuardConfig::DEFAULT },
            ..config
        };
        let first = if alone { 0 } else { keyboard };
        let mut rig = Rig::new(config);
        let end = common::run_steps(&mut rig, &steps, |_| {});
        rig.run_until(end + Duration::from_secs(60));
        let end = rig.now;
        assert_strikes_kept(&rig.timeline, first, pulse, end);
        rig.all_off(end);
        prop_assert_eq!(rig.last, [0; 4]);
        rig.run_until(end + Duration::from_secs(3_600));
        prop_assert_eq!(rig.last, [0; 4]);
    }

    /// Chunked = whole: the same bytes fed one at a time at their instants, or all at once
    /// per instant, give the same board timeline on a mixed robot.
    #[test]
    fn a_mixed_robot_plays_the_same_fed_byte_by_byte(steps in band_steps(), keyboard in 12u8..=51) {
        let config = mixed(keyboard, Pulse::DRUM);
        let mut whole = Rig::new(config);
        let mut bytes = Rig::new(config);
        let mut t = 0;
        for step in &steps {
            t += step.gap;
            let at = Instant::from_micros(t);
            if let Some(b) = &step.bytes {
                whole.feed(b, at);
                for &x in b {
                    bytes.feed(&[x], at);
                }
            }
        }
        whole.run_until(Instant::from_micros(t + 10_000_000));
        bytes.run_until(Instant::from_micros(t + 10_000_000));
        prop_assert_eq!(&whole.timeline, &bytes.timeline);
        prop_assert_eq!(whole.robot.stats(), bytes.robot.stats());
    }
}

#[test]
fn a_glockenspiel_folds_by_octaves_and_strikes_every_bar() {
    let range = KeyRange::new(Note::from_bits(79), Note::from_bits(108)).unwrap();
    let mut strikes = Strikes {
        keyboard: false,
        ..Strikes::NONE
    };
    strikes
        .push_pitched(ChannelMask::ALL, 0, range, OutOfRange::Fold, Pulse::DRUM)
        .unwrap();
    let config = Config {
        layout: Layout::sequential([0x21, 0x22, 0x23, 0x24], 30),
        strikes,
        ..Config::THESIS
    };
    let mut rig = Rig::new(config);
    let mut events = Vec::new();
    for (i, n) in (79u8..=108).chain([60, 120]).enumerate() {
        rig.run_until(ms(i as u64 * 100));
        rig.robot
            .feed_slice_with(&[0x90, n, 100], ms(i as u64 * 100), &mut |e| events.push(e));
        rig.flush(ms(i as u64 * 100));
    }
    rig.run_until(ms(10_000));
    let struck: Vec<(u8, i8)> = events
        .iter()
        .filter_map(|e| match e {
            NoteEvent::Struck { at, .. } => Some((at.key, at.octaves)),
            _ => None,
        })
        .collect();
    assert_eq!(struck.len(), 32);
    assert_eq!(struck[30], (60 + 24 - 79, 2), "C4 up two octaves to C6");
    assert_eq!(struck[31], (120 - 12 - 79, -1), "C9 down one to C8");
    assert_eq!(rig.timeline.len(), 64, "every strike went up again");
}
