//! Following a conductor on the virtual clock: the source's bytes are fed at their times,
//! the follower's tempo goes to the performer through `Control`, and the performance's
//! position is checked against the conductor's beats.

use orch_perform::conduct::{encode_osc, OscArg};
use orch_perform::{
    song_events, Action, Control, Cue, Follow, Follower, MidiClock, MidiRecording, OscCues,
    Performer, ScoreBeats, Timed,
};
use orch_seq::Song;

mod common;

use testkit::smf;

/// [`smf::quarters_smf`] parsed.
fn quarters(beats: u32, bpm: f64) -> Song {
    Song::parse(&smf::quarters_smf(beats, bpm)).unwrap()
}

/// MIDI clock from `from` to `to` BPM over `ramp` beats, then steady for `hold` beats: the
/// times of its clocks, from the first (the first beat, at the score's start).
fn clock_ramp(from: f64, to: f64, ramp: u32, hold: u32) -> Vec<u64> {
    let mut t = 0.0;
    let mut v = Vec::new();
    for b in 0..ramp + hold {
        let bpm = from + (to - from) * f64::from(b.min(ramp)) / f64::from(ramp);
        let beat = 60e6 / bpm;
        for i in 0..24 {
            v.push((t + beat * f64::from(i) / 24.0).round() as u64);
        }
        t += beat;
    }
    v.push(t.round() as u64);
    v
}

/// Plays `song` following a MIDI clock (Start, then `clocks`) with `follow`; returns, at each
/// of the clock's beats, the performance's position minus the beat's number (in beats), the
/// last tempo factor, and the report's checks.
fn follow_clock(song: &Song, clocks: &[u64], follow: Follow) -> (Vec<f64>, f64) {
    let control = Control::new();
    let beats = ScoreBeats::of(song);
    let mut follower = Follower::new(beats.clone(), follow);
    let mut decoder = MidiClock::new();
    let mut errors = Vec::new();
    let mut times = vec![0u64];
    times.extend_from_slice(clocks);
    let mut first = true;
    let mut clock = Conducted::new(&control, times, |t: u64, k, c: &Control| {
        if k.is_none() {
            // Woken with no clock byte.
            follower.wake(t, c.time_map().as_ref()).apply(c, t);
            return follower.due();
        }
        // Start comes just before the first clock (at the same µs here).
        let byte = if std::mem::take(&mut first) {
            0xFA
        } else {
            0xF8
        };
        let Some(cue) = decoder.feed(t, byte) else {
            return follower.due();
        };
        let map = c.time_map();
        if let (Cue::Beat { t_us, .. }, Some(m)) = (cue, map) {
            let (pos, _) = beats.at(m.score(t_us as i64));
            errors.push(pos - errors.len() as f64);
        }
        if let Action::Tempo(tempo) = follower.cue(&Timed { t_us: t, cue }, map.as_ref()) {
            c.set_tempo(tempo);
        }
        follower.due()
    });
    let mut live = |_: &orch_perform::Live| {};
    let played = Performer::new(&setup(), song_events(song), song.notes())
        .clock(&mut clock)
        .control(&control)
        .live(&mut live)
        .run()
        .unwrap();
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.unmatched, 0);
    assert_eq!(r.outcomes.dropped.total(), 0, "{r:?}");
    // Every note struck once: on time or late, never twice, never skipped.
    assert_eq!(r.strikes, song.notes() as u64);
    let factor = control.time_map().unwrap().tempo().get();
    (errors, factor)
}

#[test]
fn a_midi_clock_speeding_up_from_100_to_130_bpm_is_followed_within_two_beats() {
    // The score is written at 100 BPM; the conductor's clock goes from 100 to 130 over 32
    // beats and holds 130 for 24 more. Not following, the performance would end 9 beats behind.
    let song = quarters(64, 100.0);
    let clocks = clock_ramp(100.0, 130.0, 32, 24);
    for follow in [Follow::Immediate, Follow::PHASE] {
        let (errors, factor) = follow_clock(&song, &clocks, follow);
        assert_eq!(errors.len(), 57, "{follow:?}");
        let worst = errors.iter().fold(0f64, |a, e| a.max(e.abs()));
        let last = errors.last().unwrap();
        println!(
            "{follow:?}: position - beat, worst {worst:.3} beats, at the last beat {last:+.3}; \
             tempo at the end {:.1} BPM",
            factor * 100.0
        );
        assert!(worst <= 2.0, "{follow:?}: {errors:?}");
        assert!((factor * 100.0 - 130.0).abs() < 1.0, "{follow:?}: {factor}");
        if matches!(follow, Follow::Phase { .. }) {
            // The phase is pulled in: at the end the beats and the score's quarters agree.
            assert!(last.abs() < 0.05, "{errors:?}");
        }
    }
}

#[test]
fn osc_tempo_messages_are_parsed_and_applied() {
    let song = quarters(16, 120.0);
    let control = Control::new();
    let mut follower = Follower::new(ScoreBeats::of(&song), Follow::Immediate);
    let mut osc = OscCues::new();
    // At 2 s into the score the conductor says 90 BPM, as a float; at 4 s, 180 as a double.
    let packets = [
        encode_osc("/orch/tempo", &[OscArg::Float(90.0)]),
        encode_osc("/orch/tempo", &[OscArg::Double(180.0)]),
    ];
    let mut applied = Vec::new();
    let mut k = 0;
    let mut clock = Conducted::new(
        &control,
        vec![2_000_000, 4_000_000],
        |t: u64, _, c: &Control| {
            for cue in osc.packet(t, &packets[k]).unwrap() {
                let cue = Timed { t_us: t, cue };
                if let Action::Tempo(tempo) = follower.cue(&cue, c.time_map().as_ref()) {
                    c.set_tempo(tempo);
                    applied.push(tempo.get());
                }
            }
            k += 1;
            None
        },
    );
    let mut live = |_: &orch_perform::Live| {};
    let played = Performer::new(&setup(), song_events(&song), song.notes())
        .clock(&mut clock)
        .control(&control)
        .live(&mut live)
        .run()
        .unwrap();
    assert_eq!(applied, vec![0.75, 1.5]);
    let r = played.report(None);
    assert_eq!(r.strikes, 16);
    // Where each note was due on the wall clock: 4 intervals at 120 BPM (2 s), 3 at 90 (2 s),
    // the last 8 at 180 (2.67 s). A change wakes the performer as it arrives (it waited up to
    // 40 ms for its next look before: these spans were off by up to 30 and 15 ms then).
    let due: Vec<i64> = played.records.iter().map(|r| r.score_at_us).collect();
    let span = due[15] - due[0];
    assert!((span - 6_666_667).abs() < 1_000, "{due:?}");
    assert!((due[7] - due[4] - 2_000_000).abs() < 1_000, "{due:?}");
}

/// A MIDI clock master's transport, as a sequencer sends it: Start and four beats of clock at
/// 120 BPM, Stop, Song Position to bar 5 (64 sixteenths), Continue, and clock on. The
/// performance pauses, jumps to bar 5 of the score and goes on from there: the first note
/// after Continue is the first of bar 5, every later note once and in order.
#[test]
fn song_position_from_a_midi_clock_lands_on_its_bar() {
    let song = quarters(32, 120.0);
    let bar5 = song.bar_start_us(5).unwrap();
    assert_eq!(bar5, 8_000_000);
    let clock_us = 500_000 / 24;
    let mut input: Vec<(u64, Vec<u8>)> = vec![(0, vec![0xFA])];
    input.extend((0..96).map(|i| (i * clock_us, vec![0xF8])));
    input.push((2_000_000, vec![0xFC]));
    // 64 = 0x40: LSB 0x40, MSB 0; a clock byte inside the message, as real time allows.
    input.push((2_200_000, vec![0xF2, 0x40, 0xF8, 0x00]));
    input.push((2_500_000, vec![0xFB]));
    input.extend((0..24 * 17).map(|i| (2_500_000 + i * clock_us, vec![0xF8])));
    let control = Control::new();
    let mut follower = Follower::new(ScoreBeats::of(&song), Follow::PHASE);
    let mut decoder = MidiClock::new();
    let times = input.iter().map(|(t, _)| *t).collect();
    let mut k = 0;
    let mut jump_asked = None;
    let mut clock = Conducted::new(&control, times, |t: u64, _, c: &Control| {
        for &b in &input[k].1 {
            if let Some(cue) = decoder.feed(t, b) {
                let action = follower.cue(&Timed { t_us: t, cue }, c.time_map().as_ref());
                if let Action::Jump(to) = action {
                    jump_asked = Some(to);
                }
                action.apply(c, t);
            }
        }
        k += 1;
        None
    });
    let mut views = Vec::new();
    let mut live = |l: &orch_perform::Live| views.push((l.song_us, l.paused));
    let mut out = MidiRecording::default();
    let played = Performer::new(&setup(), song_events(&song), song.notes())
        .clock(&mut clock)
        .control(&control)
        .midi(&mut out)
        .live(&mut live)
        .run()
        .unwrap();
    assert_eq!(jump_asked, Some(bar5));
    // Paused, the view shows where it will go on: bar 5.
    assert!(views.iter().any(|&(s, p)| p && s == bar5), "{views:?}");
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    // The Start as it began changed nothing; the Song Position was one jump.
    assert_eq!((r.jumps, r.replayed), (1, 0), "{r:?}");
    // Notes 0 to 4 (the fifth sent early, before Stop), then bar 5's on.
    let ons: Vec<u8> = common::note_ons(&out);
    let score: Vec<u8> = (0..32).map(|i| 48 + (i % 24) as u8).collect();
    let played_before = ons.len() - 16;
    assert_eq!(ons[..played_before], score[..played_before]);
    assert_eq!(ons[played_before..], score[16..], "{ons:?}");
    assert_eq!(r.outcomes.skipped as usize, 16 - played_before, "{r:?}");
}

use testkit::conducted::{self, conduct, input, setup, Conducted, Run, Via};

/// The worst |error| (ms) over `range` of the notes.
fn worst(errors: &[f64], range: std::ops::Range<usize>) -> f64 {
    errors[range].iter().fold(0f64, |a, e| a.max(e.abs()))
}

/// No beat of the performance pulled by a sixteenth note: each quarter of the score took the
/// performance between 0.75 and 1.25 of the conductor's beat as the follower had it then
/// (what it plays at without pulling the phase), every note, the change's too; and no tempo
/// asked would, held for a beat (a quarter in 0.75 to 1.25 of the follower's period).
fn no_pull_lurches(run: &Run) {
    let b = run.beats_per_quarter();
    assert!(
        b.iter().all(|&x| (x - 1.0).abs() < 0.25),
        "a quarter against the follower's beat: {b:.3?}"
    );
    assert!(
        run.pulls.iter().all(|&p| (1.0 / p - 1.0).abs() < 0.25),
        "the tempos asked against the follower's rate: {:.3?}",
        run.pulls
    );
}

/// No beat of the performance longer or shorter than the conductor's by a sixteenth note:
/// the interval between notes k − 1 and k against beats k − 1 to k, for k in `from..`.
fn no_lurch(run: &Run, beats: &[u64], from: usize) {
    for k in from..beats.len().min(run.sounds.len()) {
        let ioi = (run.sounds[k] - run.sounds[k - 1]) as f64;
        let beat = (beats[k] - beats[k - 1]) as f64;
        assert!(
            (ioi / beat - 1.0).abs() < 0.25,
            "note {k}: {ioi} µs against a beat of {beat}: {:?}",
            run.sounds
        );
    }
}

#[test]
fn an_abrupt_change_is_followed_from_its_third_beat_faster_and_its_fifth_slower() {
    // 16 beats at one tempo, then 16 at the other; the score written at the first. The change
    // is at beat 16 (its first interval ends at beat 17) and recognised at beat 18. Faster,
    // every note within 25 ms from the change's 3rd beat (beat 19): the early beat 17 is
    // caught up from the moment it can no longer be an invented one. Slower, from its 5th
    // (beat 21): the 3rd and the 4th cannot be reached by any follower that keeps the rules
    // (see the follower's notes).
    for (from, to, settled) in [(100.0, 130.0, 19), (130.0, 90.0, 21)] {
        let beats = conducted::abrupt(from, 16, to, 16);
        let song = quarters(34, from);
        for via in [Via::Osc, Via::Clock] {
            let run = conduct(&song, &input(&beats, via), via, Follow::PHASE);
            let e = run.errors_ms(&beats);
            println!("{from}->{to} via {via:?}: note - beat, ms: {e:.1?}");
            assert!(worst(&e, 0..17) <= 25.0, "{from}->{to} {via:?}: {e:.1?}");
            assert!(
                worst(&e, settled..33) <= 25.0,
                "{from}->{to} {via:?}: {e:.1?}"
            );
            // No overshoot past 25 ms on the far side: a speeding up leaves the notes late
            // until they catch up, never early; a slowing down, the other way.
            if to > from {
                assert!(e.iter().all(|&x| x >= -25.0), "{via:?}: {e:.1?}");
            } else {
                assert!(e.iter().all(|&x| x <= 25.0), "{via:?}: {e:.1?}");
            }
            no_pull_lurches(&run);
            no_lurch(&run, &beats, 18);
            // The rate jumped at the change's second beat (beat 18: the 19th cue), not before.
            let bpm = run.bpm[18];
            assert!((bpm - to).abs() < 1.0, "{via:?}: {:?}", run.bpm);
            assert!((run.bpm[17] - from).abs() < 1.0, "{via:?}: {:?}", run.bpm);
        }
    }
}

#[test]
fn an_accelerando_is_followed_within_25_ms_from_its_third_beat() {
    // 8 beats at 80 BPM, 16 stepping up to 140, 8 at 140; the score written at 80.
    let beats = conducted::ramp(80.0, 140.0, 8, 16, 8);
    let song = quarters(34, 80.0);
    for via in [Via::Osc, Via::Clock] {
        let run = conduct(&song, &input(&beats, via), via, Follow::PHASE);
        let e = run.errors_ms(&beats);
        println!("accelerando 80->140 via {via:?}: note - beat, ms: {e:.1?}");
        assert!(worst(&e, 0..9) <= 25.0, "{via:?}: {e:.1?}");
        assert!(worst(&e, 11..33) <= 25.0, "{via:?}: {e:.1?}");
        no_lurch(&run, &beats, 1);
        no_pull_lurches(&run);
    }
}

/// A change made to a conductor's beats.
type Change = dyn Fn(&mut Vec<u64>);

/// The conductor at 110 BPM over a score written at 100, 24 beats: the notes' sounds as
/// conducted, and with `change` made to the beats.
fn with_and_without(change: impl Fn(&mut Vec<u64>)) -> (Run, Run, Vec<u64>) {
    let beats = conducted::abrupt(110.0, 24, 110.0, 0);
    let song = quarters(26, 100.0);
    let plain = conduct(&song, &input(&beats, Via::Osc), Via::Osc, Follow::PHASE);
    let mut odd = beats.clone();
    change(&mut odd);
    let changed = conduct(&song, &input(&odd, Via::Osc), Via::Osc, Follow::PHASE);
    (plain, changed, beats)
}

/// The largest difference between two runs' sounds, ms.
fn moved_ms(a: &Run, b: &Run) -> f64 {
    a.sounds
        .iter()
        .zip(&b.sounds)
        .map(|(x, y)| (x - y).abs() as f64 / 1000.0)
        .fold(0.0, f64::max)
}

#[test]
fn a_missed_or_invented_beat_moves_no_note_by_more_than_25_ms() {
    let (plain, _, beats) = with_and_without(|_| {});
    let e = plain.errors_ms(&beats);
    assert!(worst(&e, 3..25) <= 25.0, "{e:.1?}");
    let cases: [(&str, Box<Change>); 4] = [
        (
            "missed beat 12",
            Box::new(|b| {
                b.remove(12);
            }),
        ),
        (
            "invented beat at 12.5",
            Box::new(|b| {
                b.insert(13, (b[12] + b[13]) / 2);
            }),
        ),
        (
            "invented beat at 12.3",
            Box::new(|b| {
                b.insert(13, b[12] + (b[13] - b[12]) * 3 / 10);
            }),
        ),
        (
            "invented beat at 12.8",
            Box::new(|b| {
                b.insert(13, b[12] + (b[13] - b[12]) * 8 / 10);
            }),
        ),
    ];
    for (name, change) in cases {
        let (plain, odd, _) = with_and_without(change);
        let moved = moved_ms(&plain, &odd);
        println!("{name}: the notes moved by at most {moved:.2} ms");
        assert!(moved <= 25.0, "{name}: {moved} ms");
        no_pull_lurches(&odd);
        // The tempo is not taken from the odd interval.
        assert!(
            odd.bpm.iter().skip(2).all(|b| (b - 110.0).abs() < 3.0),
            "{name}: {:?}",
            odd.bpm
        );
    }
}

#[test]
fn a_fermata_is_not_taken_as_a_new_tempo() {
    // 90 BPM over a score written at 90; after beat 11 the conductor holds 2.5 s, then goes on
    // at 90. The performance plays on through the hold (it cannot know); after it the phase
    // is found again and the tempo stays.
    let mut beats = conducted::abrupt(90.0, 24, 90.0, 0);
    for b in &mut beats[12..] {
        *b += 2_500_000;
    }
    let song = quarters(34, 90.0);
    let run = conduct(&song, &input(&beats, Via::Osc), Via::Osc, Follow::PHASE);
    assert!(
        run.bpm.iter().skip(1).all(|b| (b - 90.0).abs() < 1.0),
        "{:?}",
        run.bpm
    );
    // No beat of the performance lurches by a sixteenth (the conductor's beat is 667 ms).
    for w in run.sounds.windows(2) {
        let ioi = (w[1] - w[0]) as f64;
        assert!((ioi / 666_667.0 - 1.0).abs() < 0.25, "{:?}", run.sounds);
    }
    no_pull_lurches(&run);
    // From the third beat after the hold, a note within 25 ms of every beat.
    for &b in &beats[15..] {
        let near = run
            .sounds
            .iter()
            .map(|&s| (s - b as i64).abs())
            .min()
            .unwrap();
        assert!(near <= 25_000, "beat at {b}: {near} µs: {:?}", run.sounds);
    }
}
