//! The MIDI byte sink: a robot that interprets MIDI itself, over a DIN line, with the virtual
//! robot as its copy at the far end; and the bytes read back the way a serial port returns
//! them, in chunks that cut messages, give the same performance.

use orch_core::NoteEvent;
use orch_perform::{
    sim_boards, song_events, DinWire, Link, LocalRobot, MidiRecording, Performer, ScoreEvent,
};
use orch_seq::WireBytes;

mod common;

use common::{corpus_song as corpus, setup};

#[test]
fn a_din_line_carries_every_note_with_running_status_and_compensation_counts_its_time() {
    let song = corpus("bach-invention-01.mid");
    let mut out = MidiRecording::default();
    let played = Performer::new(&setup(Link::Din), song_events(&song), song.notes())
        .midi(&mut out)
        .run()
        .unwrap();
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.unmatched, 0);
    // A two-voice invention on two channels: two notes at one instant are 6 bytes on the
    // line, centred on their time (±0.48 ms), so nearly every note lands within 1 ms.
    assert!(r.onset_ms.median <= 0.5, "{:?}", r.onset_ms);
    assert!(r.outcomes.on_time as f64 >= 0.95 * r.notes as f64, "{r:?}");
    // Running status: a status byte is sent only when it changes.
    let mut status = 0u8;
    let mut left_out = 0;
    for (_, b) in &out.sent {
        match b[0] {
            0x80..=0xEF => {
                assert_ne!(b[0], status, "a repeated status byte was sent");
                status = b[0];
            }
            0xF0..=0xF7 => status = 0,
            0xF8..=0xFF => {}
            _ => {
                assert_ne!(status, 0, "running status without a status");
                left_out += 1;
            }
        }
    }
    assert!(left_out > 0);
    // The robot is told to let go of everything at the end.
    let offs = out
        .sent
        .iter()
        .rev()
        .take(16)
        .filter(|(_, b)| b.len() >= 2 && b[b.len() - 2] == 123)
        .count();
    assert_eq!(offs, 16);
}

#[test]
fn a_ten_note_chord_on_din_spreads_over_about_six_ms_and_the_report_says_so() {
    let mut ev = Vec::new();
    for i in 0..10u8 {
        ev.push(ScoreEvent {
            score_us: 100_000,
            bytes: WireBytes::new(&[0x90, 48 + 2 * i, 100]),
        });
    }
    for i in 0..10u8 {
        ev.push(ScoreEvent {
            score_us: 600_000,
            bytes: WireBytes::new(&[0x80, 48 + 2 * i, 0]),
        });
    }
    let mut out = MidiRecording::default();
    let played = Performer::new(&setup(Link::Din), ev.into_iter(), 10)
        .midi(&mut out)
        .run()
        .unwrap();
    let r = played.report(None);
    assert!(r.adds_up());
    assert_eq!(r.strikes, 10);
    let sounds: Vec<u64> = played
        .performance
        .sounds
        .iter()
        .filter(|s| s.kind == orch_sim::SoundKind::Down)
        .map(|s| s.time.as_micros())
        .collect();
    let spread = sounds.iter().max().unwrap() - sounds.iter().min().unwrap();
    // 3 + 9 × 2 bytes of 320 µs: the first arrives 5.76 ms before the last.
    assert!((5_500..=6_500).contains(&spread), "{spread} µs");
    // Compensation centres the chord on its time: no note more than half the spread off.
    assert!(r.onset_ms.max <= 3.5, "{:?}", r.onset_ms);
}

/// A corpus file as the bytes of a DIN line: (arrival µs, byte).
fn din_stream(file: &str) -> Vec<(u64, u8)> {
    let song = corpus(file);
    let mut out = MidiRecording::default();
    Performer::new(&setup(Link::Din), song_events(&song), song.notes())
        .midi(&mut out)
        .run()
        .unwrap();
    let mut wire = DinWire::default();
    let mut stream = Vec::new();
    for (t, bytes) in &out.sent {
        for (at, &b) in wire
            .arrivals(*t, bytes.len())
            .collect::<Vec<_>>()
            .iter()
            .zip(bytes)
        {
            stream.push((*at, b));
        }
    }
    stream
}

/// Feeds timed bytes to a fresh robot, each `cuts`-delimited run of bytes as one slice at the
/// time of its first byte (all bytes of a run share it), and returns every board edge and the
/// interpreter's decisions.
/// Board edges (µs, key, high) and note decisions.
type Replayed = (Vec<(u64, Option<u8>, bool)>, Vec<NoteEvent>);

fn replay(stream: &[(u64, u8)], cuts: &[usize]) -> Replayed {
    let s = setup(Link::Din);
    let mut robot = LocalRobot::new(s.config, sim_boards(&s.sim).unwrap()).unwrap();
    let mut decided = Vec::new();
    let mut from = 0;
    for &to in cuts.iter().chain(std::iter::once(&stream.len())) {
        // A run may hold bytes of several read times: feed each time's bytes as one slice.
        let mut i = from;
        while i < to {
            let t = stream[i].0;
            let j = (i..to).find(|&j| stream[j].0 != t).unwrap_or(to);
            let bytes: Vec<u8> = stream[i..j].iter().map(|x| x.1).collect();
            robot.feed(t, &bytes).unwrap();
            i = j;
        }
        decided.extend(robot.take_decided().into_iter().map(|d| d.event));
        from = to;
    }
    let end = robot.drain(stream.last().unwrap().0 + 1).unwrap();
    decided.extend(robot.take_decided().into_iter().map(|d| d.event));
    let (_, perf) = robot.finish(end + 100_000);
    let edges = perf
        .edges
        .iter()
        .map(|e| (e.time.as_micros(), e.key, e.high))
        .collect();
    (edges, decided)
}

/// Random cut positions, 1 to `max` bytes apart.
fn cuts(len: usize, max: u64, seed: &mut u64) -> Vec<usize> {
    let mut v = Vec::new();
    let mut at = 0usize;
    loop {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        at += 1 + (*seed % max) as usize;
        if at >= len {
            return v;
        }
        v.push(at);
    }
}

#[test]
fn bytes_read_in_chunks_that_cut_messages_give_the_same_performance() {
    // The line as a serial port returns it: reads of 1 to 7 bytes, each at the time its last
    // byte arrived, cutting messages anywhere (running status included).
    let line = din_stream("bach-invention-01.mid");
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let reads = cuts(line.len(), 7, &mut seed);
    let mut stream = line.clone();
    let mut from = 0;
    for &to in reads.iter().chain(std::iter::once(&line.len())) {
        let t = line[to - 1].0;
        for x in &mut stream[from..to] {
            x.0 = t;
        }
        from = to;
    }
    // Fed byte by byte, as read (one slice a read), and in other chunks that cross both
    // messages and reads: the same edges at the same times, the same decisions.
    let every: Vec<usize> = (1..stream.len()).collect();
    let (edges, decided) = replay(&stream, &every);
    assert!(edges.len() > 800, "{}", edges.len());
    assert!(decided.len() >= 458, "a decision a note at least");
    assert_eq!(replay(&stream, &reads), (edges.clone(), decided.clone()));
    for round in 0..6 {
        let other = cuts(stream.len(), 11, &mut seed);
        let (e, d) = replay(&stream, &other);
        let first = d.iter().zip(&decided).position(|(a, b)| a != b);
        assert!(
            first.is_none() && d.len() == decided.len(),
            "round {round}: decision {first:?}"
        );
        let first = e.iter().zip(&edges).position(|(a, b)| a != b);
        assert!(
            first.is_none() && e.len() == edges.len(),
            "round {round}: edge {first:?}"
        );
    }
}
