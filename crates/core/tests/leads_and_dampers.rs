//! Leads and dampers: an open hi-hat fires its lift, then its stick; a crash's damper fires at
//! the Note-Off, after the beater's pulse, not while the pedal holds, and never while its
//! beater strikes. Rules worked by hand first, then properties over any byte stream.

mod common;

use common::{ms, Edge, Rig};
use orch_core::{ChannelMask, Config, Duration, Layout, Note, NoteEvent, Pulse, Strikes};
use proptest::prelude::*;

/// Channel 10 (0-based 9).
const DRUMS: u8 = 9;
const KICK: u8 = 0;
const STICK: u8 = 2;
const LIFT: u8 = 3;
const CRASH: u8 = 4;
const DAMPER: u8 = 5;
const LEAD: Duration = Duration::from_millis(15);

fn pulse(soft: u32, loud: u32, rebound: u32) -> Pulse {
    Pulse {
        soft: Duration::from_millis(soft),
        loud: Duration::from_millis(loud),
        rebound: Duration::from_millis(rebound),
    }
}

/// Kick, snare, hi-hat stick (42 closed, 46 open), its lift (the lead of 46), crash (49)
/// and the crash's damper, from key 0 on board 0.
fn kit(drum: Pulse) -> Config<4> {
    let mut s = Strikes {
        keyboard: false,
        ..Strikes::NONE
    };
    let lift = pulse(60, 60, 80);
    let damper = pulse(30, 30, 60);
    s.push_kit(
        ChannelMask(1 << DRUMS),
        0,
        &[
            (&[35, 36], drum),
            (&[38], drum),
            (&[42, 46], drum),
            (&[], lift),
            (&[49], drum),
            (&[], damper),
        ],
    )
    .unwrap();
    s.set_lead(0, Note::from_bits(46), LIFT, LEAD);
    s.set_damper(CRASH, DAMPER);
    Config {
        layout: Layout::sequential([0x21, 0x22, 0x23, 0x24], 6),
        strikes: s,
        ..Config::THESIS
    }
}

fn edges(rig: &Rig, bit: u8) -> Vec<(u64, bool)> {
    rig.timeline
        .iter()
        .filter(|e| e.board == 0 && e.bit == bit)
        .map(|e| (e.t.as_micros(), e.on))
        .collect()
}

fn on(note: u8, velocity: u8) -> [u8; 3] {
    [0x90 | DRUMS, note, velocity]
}

fn off(note: u8) -> [u8; 3] {
    [0x80 | DRUMS, note, 0]
}

#[test]
fn an_open_hi_hat_fires_its_lift_then_its_stick_a_lead_time_later() {
    let mut rig = Rig::new(kit(Pulse::DRUM));
    let mut events = Vec::new();
    rig.robot
        .feed_slice_with(&on(46, 127), ms(0), &mut |e| events.push(e));
    rig.flush(ms(0));
    rig.run_until(ms(1_000));
    assert_eq!(edges(&rig, LIFT), [(0, true), (60_000, false)]);
    assert_eq!(edges(&rig, STICK), [(15_000, true), (35_000, false)]);
    assert!(
        matches!(events[0], NoteEvent::Leading { at, .. } if at.key == STICK),
        "{events:?}"
    );
    // The closed hi-hat plays the stick alone, at once.
    rig.feed(&on(42, 127), ms(1_000));
    rig.run_until(ms(2_000));
    assert_eq!(edges(&rig, STICK)[2], (1_000_000, true));
    assert_eq!(edges(&rig, LIFT).len(), 2);
    let s = rig.robot.stats();
    assert_eq!((s.played, s.restrikes_delayed, s.extras_skipped), (2, 0, 0));
}

#[test]
fn the_lead_waits_for_the_sticks_rebound_and_a_lift_in_its_rebound_is_skipped() {
    let mut rig = Rig::new(kit(Pulse::DRUM));
    rig.feed(&on(46, 127), ms(0));
    // 20 ms later: the lift is on (its pulse is 60 ms), the stick is within its 40 ms
    // rebound of its strike at 15 ms: it waits for it, to 55 ms.
    rig.feed(&on(46, 127), ms(40));
    rig.run_until(ms(1_000));
    assert_eq!(edges(&rig, LIFT), [(0, true), (60_000, false)]);
    assert_eq!(
        edges(&rig, STICK),
        [
            (15_000, true),
            (35_000, false),
            (55_000, true),
            (75_000, false)
        ]
    );
    assert_eq!(rig.robot.stats().extras_skipped, 1);
    assert_eq!(rig.robot.stats().played, 2);
}

#[test]
fn a_dampers_pulse_comes_at_the_note_off_after_the_beaters_pulse() {
    let mut rig = Rig::new(kit(Pulse::DRUM));
    // A long note: the damper at its Note-Off.
    rig.feed(&on(49, 127), ms(0));
    rig.feed(&off(49), ms(500));
    // A short one: its Note-Off within the beater's 20 ms pulse; the damper when it ends.
    rig.feed(&on(49, 127), ms(1_000));
    rig.feed(&off(49), ms(1_005));
    rig.run_until(ms(3_000));
    assert_eq!(
        edges(&rig, CRASH),
        [
            (0, true),
            (20_000, false),
            (1_000_000, true),
            (1_020_000, false)
        ]
    );
    assert_eq!(
        edges(&rig, DAMPER),
        [
            (500_000, true),
            (530_000, false),
            (1_020_000, true),
            (1_050_000, false)
        ]
    );
    // Other drums have no damper: their Note-Off does nothing.
    rig.feed(&on(38, 127), ms(3_000));
    rig.feed(&off(38), ms(3_100));
    rig.run_until(ms(4_000));
    assert_eq!(edges(&rig, DAMPER).len(), 4);
}

#[test]
fn the_sustain_pedal_holds_the_damper_until_it_goes_up() {
    // The robot follows the pedal (`sustain`, off by default: then the pedal holds nothing).
    let mut rig = Rig::new(Config {
        sustain: true,
        ..kit(Pulse::DRUM)
    });
    rig.feed(&[0xB0 | DRUMS, 64, 127], ms(0));
    rig.feed(&on(49, 127), ms(10));
    rig.feed(&off(49), ms(100));
    rig.run_until(ms(900));
    assert!(edges(&rig, DAMPER).is_empty());
    rig.feed(&[0xB0 | DRUMS, 64, 0], ms(1_000));
    rig.run_until(ms(2_000));
    assert_eq!(edges(&rig, DAMPER), [(1_000_000, true), (1_030_000, false)]);
    // A pedal on another channel holds nothing of the kit's.
    rig.feed(&[0xB0, 64, 127], ms(2_000));
    rig.feed(&on(49, 127), ms(2_010));
    rig.feed(&off(49), ms(2_100));
    rig.run_until(ms(3_000));
    assert_eq!(edges(&rig, DAMPER)[2], (2_100_000, true));
}

#[test]
fn a_strike_cuts_its_bars_damper_and_a_new_note_cancels_an_old_damping() {
    let mut rig = Rig::new(kit(Pulse::DRUM));
    rig.feed(&on(49, 127), ms(0));
    rig.feed(&off(49), ms(100));
    // The crash again while its damper is on (100..130 ms): the damper goes off at once.
    rig.feed(&on(49, 127), ms(110));
    rig.run_until(ms(1_000));
    assert_eq!(edges(&rig, DAMPER), [(100_000, true), (110_000, false)]);
    // A Note-Off during the pulse, then the note again before the pulse ends (it joins):
    // the first note's damping is moot; no damper.
    rig.feed(&on(49, 127), ms(1_000));
    rig.feed(&off(49), ms(1_002));
    rig.feed(&on(49, 127), ms(1_004));
    rig.run_until(ms(2_000));
    assert_eq!(edges(&rig, DAMPER).len(), 2);
}

#[test]
fn all_off_and_the_watchdog_end_leads_and_dampers_and_forget_dampings() {
    let mut rig = Rig::new(kit(Pulse::DRUM));
    rig.feed(&on(46, 127), ms(0));
    rig.feed(&[0xB0 | DRUMS, 64, 127], ms(1));
    rig.feed(&on(49, 127), ms(2));
    rig.feed(&off(49), ms(3));
    rig.all_off(ms(5));
    assert_eq!(rig.last, [0; 4]);
    rig.run_until(ms(5_000));
    assert_eq!(rig.last, [0; 4]);
    assert!(edges(&rig, DAMPER).is_empty());
    // The stick waiting for the lead was stopped, not struck.
    assert_eq!(edges(&rig, STICK), []);
    assert_eq!(rig.robot.stats().dropped_stopped, 1);
}

#[test]
fn bad_leads_and_dampers_are_refused() {
    let bad = |f: &dyn Fn(&mut Strikes)| {
        let mut config = kit(Pulse::DRUM);
        f(&mut config.strikes);
        orch_core::Interpreter::<4, 61>::new(config)
            .unwrap_err()
            .to_string()
    };
    // A lead time as long as the stick's rebound.
    let e = bad(&|s| s.set_lead(0, Note::from_bits(46), LIFT, Duration::from_millis(40)));
    assert!(e.contains("note 46"), "{e}");
    // A lead that plays notes of its own.
    let e = bad(&|s| s.set_lead(0, Note::from_bits(46), KICK, LEAD));
    assert!(e.contains("lead"), "{e}");
    // A damper with notes, or shared by two outputs.
    let e = bad(&|s| s.set_damper(CRASH, KICK));
    assert!(e.contains("damper"), "{e}");
    let e = bad(&|s| s.set_damper(1, DAMPER));
    assert!(e.contains("damper"), "{e}");
}

/// A stream for the kit: its notes (and others), Note-Offs, the pedal, All Notes Off,
/// real-time bytes, resets.
fn kit_chunk() -> impl Strategy<Value = Vec<u8>> {
    let channel = prop_oneof![6 => Just(DRUMS), 1 => 0u8..16];
    let note = prop_oneof![6 => prop::sample::select(vec![36u8, 38, 42, 46, 49]), 1 => 0u8..128];
    prop_oneof![
        6 => (channel.clone(), note.clone(), 0u8..128).prop_map(|(c, n, v)| vec![0x90 | c, n, v]),
        4 => (channel.clone(), note.clone()).prop_map(|(c, n)| vec![0x80 | c, n, 64]),
        2 => (note, 1u8..128).prop_map(|(n, v)| vec![n, v]),
        2 => (channel, prop::sample::select(vec![64u8, 120, 123]), prop::sample::select(vec![0u8, 127]))
            .prop_map(|(c, k, v)| vec![0xB0 | c, k, v]),
        1 => prop::sample::select(vec![0xF8u8, 0xFE, 0xFF]).prop_map(|b| vec![b]),
    ]
}

fn kit_steps() -> impl Strategy<Value = Vec<common::Step>> {
    let gap =
        prop_oneof![3 => Just(0u64), 4 => 0u64..30_000, 2 => 0u64..200_000, 1 => 0u64..5_000_000];
    prop::collection::vec(
        (gap, prop::option::weighted(0.9, kit_chunk()))
            .prop_map(|(gap, bytes)| common::Step { gap, bytes }),
        0..80,
    )
}

/// Each output's pulses as (on, off) in µs.
fn pulses(timeline: &[Edge], bit: u8) -> Vec<(u64, u64)> {
    let mut out = Vec::new();
    let mut start = None;
    for e in timeline.iter().filter(|e| e.board == 0 && e.bit == bit) {
        let t = e.t.as_micros();
        if e.on {
            start = Some(t);
        } else {
            out.push((start.take().expect("up after down"), t));
        }
    }
    if let Some(t0) = start {
        out.push((t0, u64::MAX));
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Whatever bytes come: the crash's damper is never on while its beater is; every pulse
    /// (lift and damper too) ends within its output's loud length and keeps its rebound; and
    /// all_off leaves every output off.
    #[test]
    fn a_damper_is_never_on_with_its_beater_and_every_pulse_ends(
        steps in kit_steps(),
        sustain in any::<bool>(),
    ) {
        let mut rig = Rig::new(Config { sustain, ..kit(Pulse::DRUM) });
        let end = common::run_steps(&mut rig, &steps, |_| {});
        rig.run_until(end + Duration::from_secs(60));
        let config = kit(Pulse::DRUM);
        for bit in 0..6u8 {
            let p = config.strikes.pulse(bit);
            let list = pulses(&rig.timeline, bit);
            for &(a, b) in &list {
                prop_assert!(b - a <= p.loud.as_micros() as u64, "output {bit}: {a}..{b}");
            }
            for w in list.windows(2) {
                prop_assert!(w[1].0 - w[0].0 >= p.rebound.as_micros() as u64, "output {bit}: {w:?}");
            }
        }
        for (a, b) in pulses(&rig.timeline, CRASH) {
            for (c, d) in pulses(&rig.timeline, DAMPER) {
                prop_assert!(b <= c || d <= a, "crash {a}..{b} and its damper {c}..{d}");
            }
        }
        let now = rig.now;
        rig.all_off(now);
        prop_assert_eq!(rig.last, [0; 4]);
        rig.run_until(now + Duration::from_secs(3_600));
        prop_assert_eq!(rig.last, [0; 4]);
    }
}

/// The board writes and note events of the kit fed `steps` (their gaps in whole ms), ticked
/// at its own deadlines (`every_ms`: false) or every millisecond the exhaustive way.
fn run_ticked(steps: &[common::Step], every_ms: bool) -> Vec<(u64, String)> {
    use orch_core::{Instant, Interpreter, Recording};
    let mut robot = Interpreter::<4, 61>::new(Config {
        sustain: true,
        ..kit(pulse(20, 20, 40))
    })
    .unwrap();
    let mut log = Vec::new();
    let mut t = 0u64;
    let mut times: Vec<(u64, Option<&Vec<u8>>)> = Vec::new();
    for s in steps {
        t += s.gap / 1000 * 1000;
        times.push((t, s.bytes.as_ref()));
    }
    times.push((t + 10_000_000, None));
    let mut clock = 0u64;
    let flush = |robot: &mut Interpreter<4, 61>, at: u64, log: &mut Vec<(u64, String)>| {
        let mut boards = Recording::<8>::new();
        robot.flush(&mut boards).unwrap();
        for w in boards.writes() {
            log.push((at, format!("write {} {:016b}", w.board.index, w.outputs)));
        }
    };
    for (at, bytes) in times {
        loop {
            let next = if every_ms {
                Some(clock + 1_000).filter(|&n| n <= at)
            } else {
                robot
                    .next_deadline()
                    .map(|d| d.as_micros())
                    .filter(|&d| d <= at)
            };
            let Some(n) = next else { break };
            clock = n.max(clock);
            let mut sink = |e: NoteEvent| log.push((clock, format!("{e:?}")));
            if every_ms {
                robot.tick_exhaustive_with(Instant::from_micros(clock), &mut sink);
            } else {
                robot.tick_with(Instant::from_micros(clock), &mut sink);
            }
            flush(&mut robot, clock, &mut log);
        }
        clock = at;
        if let Some(b) = bytes {
            let mut sink = |e: NoteEvent| log.push((at, format!("{e:?}")));
            robot.feed_slice_with(b, Instant::from_micros(at), &mut sink);
            flush(&mut robot, at, &mut log);
        }
    }
    log.push((clock, format!("{:?}", robot.stats())));
    log
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Leads and dampers keep the guard's deadlines: ticked only at its own next deadline,
    /// the kit writes and reports exactly what ticking every millisecond does.
    #[test]
    fn leads_and_dampers_fire_at_the_kept_deadlines(steps in kit_steps()) {
        prop_assert_eq!(run_ticked(&steps, false), run_ticked(&steps, true));
    }

    /// Chunked = whole: the kit fed one byte at a time plays what it plays fed whole chunks.
    #[test]
    fn the_kit_plays_the_same_fed_byte_by_byte(steps in kit_steps()) {
        let config = Config { sustain: true, ..kit(Pulse::DRUM) };
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
