//! A fingered group (a wind robot): one note at a time, the fingers set with the valve closed,
//! the valve opened once they have settled, a chord's highest note played. Rules worked by
//! hand first, then properties over any byte stream.

mod common;

use common::{ms, Rig};
use orch_core::{
    ChannelMask, Config, DropReason, Duration, Fingering, KeyRange, Layout, Note, NoteEvent,
    OutOfRange, Strikes, Voice, Wind,
};
use proptest::prelude::*;

const VALVE: u8 = 0;
/// Finger `i`'s bit on board 0.
const fn finger(i: u8) -> u8 {
    1 + i
}
const CLOSE: u64 = 5;
const SETTLE: u64 = 20;

/// A three-finger pipe on channel 1, C5..=E5 (72..=76): valve on bit 0, fingers on 1..=3.
fn pipe(voice: Voice) -> Config<4> {
    let mut table = [Fingering::NONE; orch_core::wind::MAX_FINGERINGS];
    for (i, fingers) in [0b111u16, 0b110, 0b011, 0b010, 0b001]
        .into_iter()
        .enumerate()
    {
        table[i] = Fingering {
            fingers,
            breath: 2000 + 400 * i as u16,
        };
    }
    Config {
        layout: Layout::sequential([0x21, 0x22, 0x23, 0x24], 4),
        strikes: Strikes {
            keyboard: false,
            ..Strikes::NONE
        },
        wind: Wind {
            channels: ChannelMask(1),
            first: 0,
            fingers: 3,
            range: KeyRange::new(Note::from_bits(72), Note::from_bits(76)).unwrap(),
            out_of_range: OutOfRange::Fold,
            table,
            close: Duration::from_millis(CLOSE as u32),
            settle: Duration::from_millis(SETTLE as u32),
            voice,
        },
        ..Config::THESIS
    }
}

fn edges(rig: &Rig, bit: u8) -> Vec<(u64, bool)> {
    rig.timeline
        .iter()
        .filter(|e| e.board == 0 && e.bit == bit)
        .map(|e| (e.t.as_micros() / 1000, e.on))
        .collect()
}

fn fingers_at(rig: &Rig) -> u16 {
    (rig.last[0] >> 1) & 0b111
}

#[test]
fn a_note_sets_its_fingers_then_opens_the_valve_once_they_have_settled() {
    let mut rig = Rig::new(pipe(Voice::Highest));
    let mut events = Vec::new();
    rig.robot
        .feed_slice_with(&[0x90, 73, 100], ms(0), &mut |e| events.push(e));
    rig.flush(ms(0));
    rig.run_until(ms(100));
    assert_eq!(fingers_at(&rig), 0b110);
    assert_eq!(edges(&rig, VALVE), [(SETTLE, true)]);
    assert_eq!(edges(&rig, finger(1)), [(0, true)]);
    assert!(matches!(events[0], NoteEvent::Preparing { at, .. } if at.key == VALVE));
    // Its Note-Off closes the valve; the fingers let go once the air has stopped.
    rig.feed(&[0x80, 73, 0], ms(500));
    rig.run_until(ms(1_000));
    assert_eq!(edges(&rig, VALVE), [(SETTLE, true), (500, false)]);
    assert_eq!(edges(&rig, finger(1)), [(0, true), (500 + CLOSE, false)]);
    assert_eq!(rig.last, [0; 4]);
    assert_eq!(rig.robot.stats().played, 1);
}

#[test]
fn legato_closes_the_valve_moves_the_fingers_and_opens_again() {
    let mut rig = Rig::new(pipe(Voice::Highest));
    rig.feed(&[0x90, 72, 100], ms(0));
    rig.feed(&[0x80, 72, 0, 0x90, 74, 100], ms(300));
    rig.run_until(ms(1_000));
    let t = 300 + CLOSE;
    assert_eq!(
        edges(&rig, VALVE),
        [(SETTLE, true), (300, false), (t + SETTLE, true)]
    );
    // C5 (111) to D5 (011): finger 2 lifts once the valve is closed and the air stopped.
    assert_eq!(edges(&rig, finger(2)), [(0, true), (t, false)]);
    assert_eq!(fingers_at(&rig), 0b011);
}

#[test]
fn a_chord_plays_its_highest_note_and_drops_the_rest_as_monophonic() {
    let mut rig = Rig::new(pipe(Voice::Highest));
    let mut events = Vec::new();
    rig.robot
        .feed_slice_with(&[0x90, 72, 100, 76, 100, 74, 100], ms(0), &mut |e| {
            events.push(e)
        });
    rig.flush(ms(0));
    rig.run_until(ms(200));
    // 72 prepares, then 76 takes over before it sounds (72 is still held: monophonic); 74
    // comes below 76 and is dropped as it arrives.
    let reasons: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            NoteEvent::Dropped { reason, .. } | NoteEvent::WaitEnded { reason, .. } => {
                Some(*reason)
            }
            _ => None,
        })
        .collect();
    assert_eq!(reasons, [DropReason::Monophonic, DropReason::Monophonic]);
    assert_eq!(fingers_at(&rig), 0b001);
    assert_eq!(rig.robot.stats().dropped_monophonic, 2);
    // The lowest voice plays 72.
    let mut rig = Rig::new(pipe(Voice::Lowest));
    rig.feed(&[0x90, 72, 100, 76, 100, 74, 100], ms(0));
    rig.run_until(ms(200));
    assert_eq!(fingers_at(&rig), 0b111);
}

#[test]
fn a_note_released_before_its_fingers_settle_and_followed_is_too_fast() {
    let mut rig = Rig::new(pipe(Voice::Highest));
    let mut events = Vec::new();
    for (t, bytes) in [
        (0, [0x90, 72, 100]),
        (5, [0x80, 72, 0]),
        (10, [0x90, 74, 100]),
    ] {
        rig.run_until(ms(t));
        rig.robot
            .feed_slice_with(&bytes, ms(t), &mut |e| events.push(e));
        rig.flush(ms(t));
    }
    rig.run_until(ms(500));
    assert!(events.contains(&NoteEvent::WaitEnded {
        key: VALVE,
        reason: DropReason::TooFast
    }));
    // A lone note released before it settled still sounds, for min_press.
    let mut rig = Rig::new(pipe(Voice::Highest));
    rig.feed(&[0x90, 72, 100], ms(0));
    rig.feed(&[0x80, 72, 0], ms(5));
    rig.run_until(ms(500));
    assert_eq!(edges(&rig, VALVE), [(SETTLE, true), (SETTLE + 20, false)]);
}

#[test]
fn all_off_releases_the_valve_and_every_finger_at_once() {
    let mut rig = Rig::new(pipe(Voice::Highest));
    rig.feed(&[0x90, 72, 100], ms(0));
    rig.run_until(ms(100));
    rig.all_off(ms(100));
    assert_eq!(rig.last, [0; 4]);
    // A note still preparing is stopped.
    let mut rig = Rig::new(pipe(Voice::Highest));
    rig.feed(&[0x90, 72, 100], ms(0));
    rig.all_off(ms(1));
    rig.run_until(ms(1_000));
    assert_eq!(rig.last, [0; 4]);
    assert_eq!(rig.robot.stats().dropped_stopped, 1);
}

/// A stream for the pipe: its notes and others, on channel 1 and others, Note-Offs, All
/// Notes Off, real-time bytes, resets.
fn chunk() -> impl Strategy<Value = Vec<u8>> {
    let channel = prop_oneof![6 => Just(0u8), 1 => 0u8..16];
    let note = prop_oneof![6 => 70u8..79, 1 => 0u8..128];
    prop_oneof![
        6 => (channel.clone(), note.clone(), 0u8..128).prop_map(|(c, n, v)| vec![0x90 | c, n, v]),
        4 => (channel.clone(), note.clone()).prop_map(|(c, n)| vec![0x80 | c, n, 64]),
        2 => (note, 1u8..128).prop_map(|(n, v)| vec![n, v]),
        1 => channel.prop_map(|c| vec![0xB0 | c, 123, 0]),
        1 => prop::sample::select(vec![0xF8u8, 0xFE, 0xFF]).prop_map(|b| vec![b]),
    ]
}

fn steps() -> impl Strategy<Value = Vec<common::Step>> {
    let gap =
        prop_oneof![3 => Just(0u64), 4 => 0u64..30_000, 2 => 0u64..200_000, 1 => 0u64..5_000_000];
    prop::collection::vec(
        (gap, prop::option::weighted(0.9, chunk()))
            .prop_map(|(gap, bytes)| common::Step { gap, bytes }),
        0..80,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Whatever bytes come: no finger moves while the valve is open (except a full stop, the
    /// valve closing in the same write); the valve opens only after the fingers have been still
    /// for the settle time; all_off leaves everything off.
    #[test]
    fn the_valve_is_never_open_while_a_finger_moves(steps in steps()) {
        let mut rig = Rig::new(pipe(Voice::Highest));
        let end = common::run_steps(&mut rig, &steps, |_| {});
        rig.run_until(end + Duration::from_secs(60));
        let mut before = 0u16;
        let mut moved = 0u64;
        for (t, now) in rig.states.iter().map(|(t, s)| (t.as_micros(), s[0])) {
            let fingers = |s: u16| s & 0b1110;
            let valve = |s: u16| s & 1 != 0;
            if fingers(now) != fingers(before) {
                let full_stop = now == 0;
                prop_assert!(!valve(before) || full_stop, "a finger moved at {t} µs with the valve open");
                moved = t;
            }
            if valve(now) && !valve(before) {
                prop_assert!(t >= moved + SETTLE * 1000, "valve opened at {t} µs, fingers moved at {moved}");
            }
            before = now;
        }
        let now = rig.now;
        rig.all_off(now);
        prop_assert_eq!(rig.last, [0; 4]);
        rig.run_until(now + Duration::from_secs(3_600));
        prop_assert_eq!(rig.last, [0; 4]);
    }

    /// Chunked = whole.
    #[test]
    fn the_pipe_plays_the_same_fed_byte_by_byte(steps in steps()) {
        let config = pipe(Voice::Highest);
        let (mut whole, mut bytes) = (Rig::new(config), Rig::new(config));
        let mut t = 0;
        for step in &steps {
            t += step.gap;
            let at = orch_core::Instant::from_micros(t);
            if let Some(b) = &step.bytes {
                whole.feed(b, at);
                for &x in b {
                    bytes.feed(&[x], at);
                }
            }
        }
        let end = orch_core::Instant::from_micros(t + 10_000_000);
        whole.run_until(end);
        bytes.run_until(end);
        prop_assert_eq!(&whole.timeline, &bytes.timeline);
        prop_assert_eq!(whole.robot.stats(), bytes.robot.stats());
    }
}

#[test]
fn the_hold_limit_on_a_finger_stops_the_whole_group_valve_and_all() {
    let mut config = pipe(Voice::Highest);
    config.guard.max_hold = Some(Duration::from_millis(1_000));
    let mut rig = Rig::new(config);
    rig.feed(&[0x90, 72, 100], ms(0));
    rig.run_until(ms(5_000));
    // The fingers went down at 0 and the valve at 20 ms; the fingers' hold limit at 1 s cuts
    // every output in one write, the valve with them.
    assert_eq!(edges(&rig, VALVE), [(SETTLE, true), (1_000, false)]);
    assert_eq!(edges(&rig, finger(0)), [(0, true), (1_000, false)]);
    assert_eq!(rig.last, [0; 4]);
    assert!(rig.robot.stats().cut_by_hold_limit >= 1);
}

#[test]
fn on_a_pwm_board_the_valve_opens_at_the_notes_breath() {
    let config = Config {
        dynamics: orch_core::Dynamics::PWM,
        ..pipe(Voice::Highest)
    };
    let valve_duty = |note: u8| {
        let mut rig = Rig::new(config);
        rig.feed(&[0x90, note, 127], ms(0));
        rig.run_until(ms(500));
        rig.robot.tick(ms(500));
        rig.robot.key_duty(VALVE).get()
    };
    // C5's breath is 2000, E5's 3600 (of 4095): the duty follows, in proportion.
    let (low, high) = (valve_duty(72), valve_duty(76));
    assert!(low > 0 && high > low, "{low} {high}");
    assert!(
        (f64::from(high) / f64::from(low) - 1.8).abs() < 0.01,
        "{low} {high}"
    );
}
