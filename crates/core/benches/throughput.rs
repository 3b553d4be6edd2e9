//! Throughput of orch-core's MIDI decoder and interpreter, in MIDI bytes per second, against
//! midly's live stream parser (`midly::stream::MidiStream`) on the same bytes and against the
//! physical limit: a DIN MIDI line carries 3125 bytes a second (31250 baud, 10 bits a byte).
//!
//! The input is a real piano performance turned into the byte stream a sequencer would send
//! live (see `common/mod.rs`): merged tracks, running status, MIDI clock interleaved, arrival
//! times at DIN wire speed. Three measurements, in the same run:
//!
//! - (a) `orch_core::Decoder` alone, `push_slice` over the whole slice, each message
//!   black-boxed (as (c) does with midly);
//! - (b) `orch_core::Interpreter::thesis()` as a firmware would drive it: before each byte,
//!   any guard deadline that falls before it is served with `tick` and `flush`; then
//!   `feed(byte, arrival)` and `flush` into a counting `FingerBoards`;
//! - (b') the same without the `next_deadline` call before each byte, to show its cost;
//! - (c) `midly::stream::MidiStream::feed` over the whole slice, each event black-boxed.
//!
//! Each is repeated for at least 0.5 s a run; the best of 5 runs is printed. Nothing is
//! asserted about speed. Run: `cargo bench -p orch-core --bench throughput`.

mod common;

use std::hint::black_box;
use std::time::{Duration, Instant as Clock};

use common::{Stream, DIN_BYTES_PER_SEC};
use orch_core::{BoardId, Decoder, FingerBoards, Instant, Interpreter};

const RUNS: usize = 5;
const RUN_TIME: Duration = Duration::from_millis(500);

/// Counts board writes, and keeps the outputs from being optimised away.
#[derive(Default)]
struct CountingBoards {
    writes: u64,
}

impl FingerBoards for CountingBoards {
    type Error = core::convert::Infallible;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        black_box((board, outputs));
        self.writes += 1;
        Ok(())
    }
}

/// Runs `pass` (one pass over `bytes` bytes) for at least `RUN_TIME`, `RUNS` times, after a
/// warm-up; returns the best rate in bytes per second.
fn best_rate(bytes: usize, mut pass: impl FnMut()) -> f64 {
    pass();
    let mut best = 0.0f64;
    for _ in 0..RUNS {
        let start = Clock::now();
        let mut passes = 0u64;
        loop {
            pass();
            passes += 1;
            if start.elapsed() >= RUN_TIME {
                break;
            }
        }
        let rate = (passes * bytes as u64) as f64 / start.elapsed().as_secs_f64();
        best = best.max(rate);
    }
    best
}

fn decode(bytes: &[u8]) -> u32 {
    let mut decoder = Decoder::<0>::new();
    decoder.push_slice(bytes, |message| {
        black_box(message);
    });
    decoder.counters().messages
}

fn interpret(stream: &Stream, boards: &mut CountingBoards) -> u32 {
    let mut robot = Interpreter::thesis();
    for (&byte, &at) in stream.bytes.iter().zip(&stream.arrival_us) {
        let now = Instant::from_micros(at);
        while let Some(deadline) = robot.next_deadline().filter(|&d| d < now) {
            robot.tick(deadline);
            let _ = robot.flush(&mut *boards);
        }
        robot.feed(byte, now);
        let _ = robot.flush(&mut *boards);
    }
    robot.all_off(Instant::from_micros(stream.duration_us()));
    let _ = robot.flush(&mut *boards);
    robot.stats().note_ons
}

/// (b) without asking for the next deadline before each byte: `feed` still runs the guard's
/// timers itself, so this shows what the per-byte `next_deadline` call costs.
fn interpret_feed_only(stream: &Stream, boards: &mut CountingBoards) -> u32 {
    let mut robot = Interpreter::thesis();
    for (&byte, &at) in stream.bytes.iter().zip(&stream.arrival_us) {
        robot.feed(byte, Instant::from_micros(at));
        let _ = robot.flush(&mut *boards);
    }
    robot.all_off(Instant::from_micros(stream.duration_us()));
    let _ = robot.flush(&mut *boards);
    robot.stats().note_ons
}

fn midly(bytes: &[u8]) {
    let mut parser = midly::stream::MidiStream::new();
    parser.feed(bytes, |event| {
        black_box(event);
    });
    parser.flush(|event| {
        black_box(event);
    });
}

fn line(name: &str, rate: f64) {
    println!(
        "{name:<34} {:>12.0} bytes/s {:>8.2} ns/byte {:>10.0}x a DIN line",
        rate,
        1e9 / rate,
        rate / DIN_BYTES_PER_SEC,
    );
}

fn main() {
    let stream = common::realistic_stream();
    let bytes = &stream.bytes;
    println!("orch-core throughput: decoder and interpreter vs midly vs a DIN line");
    println!("stream: {}", stream.source);
    println!("        {}", stream.describe());
    if stream.synthetic {
        println!("        NOTE: synthetic input; the real-file figures need ../shared/midi");
    }

    // What each sees, once, untimed: the three must agree on the stream.
    let orch_messages = decode(bytes);
    let mut midly_events = 0u64;
    let mut parser = midly::stream::MidiStream::new();
    parser.feed(bytes, |_| midly_events += 1);
    parser.flush(|_| midly_events += 1);
    let mut boards = CountingBoards::default();
    let note_ons = interpret(&stream, &mut boards);
    let stats = {
        let mut robot = Interpreter::thesis();
        for (&byte, &at) in bytes.iter().zip(&stream.arrival_us) {
            robot.feed(byte, Instant::from_micros(at));
        }
        *robot.stats()
    };
    println!(
        "check:  orch decoder {orch_messages} messages, midly {midly_events} events; \
         interpreter {note_ons} note-ons, {} board writes ({} keys played, {} folded, \
         {} re-strikes delayed, {} refused by the power limit)",
        boards.writes, stats.played, stats.folded, stats.restrikes_delayed, stats.dropped_power,
    );
    println!(
        "timing: best of {RUNS} runs of >= {} ms each; release build; {} bytes a pass",
        RUN_TIME.as_millis(),
        bytes.len()
    );
    println!();

    let decoder = best_rate(bytes.len(), || {
        black_box(decode(black_box(bytes)));
    });
    let mut boards = CountingBoards::default();
    let interpreter = best_rate(bytes.len(), || {
        black_box(interpret(black_box(&stream), &mut boards));
    });
    let feed_only = best_rate(bytes.len(), || {
        black_box(interpret_feed_only(black_box(&stream), &mut boards));
    });
    black_box(boards.writes);
    let reference = best_rate(bytes.len(), || midly(black_box(bytes)));

    line("(a) orch_core::Decoder", decoder);
    line("(b) orch_core::Interpreter+flush", interpreter);
    line("(b') same, without next_deadline()", feed_only);
    line("(c) midly::stream::MidiStream", reference);
    println!();
    println!(
        "orch decoder / midly:     {:.2}x  (above 1: orch is faster)",
        decoder / reference
    );
    println!(
        "orch interpreter / midly: {:.2}x  (the interpreter also maps keys, runs the guard and \
         writes boards)",
        interpreter / reference
    );
    println!(
        "a DIN byte arrives every 320 us; the interpreter spends {:.1} ns on it ({:.5}% of the \
         byte time, on this host)",
        1e9 / interpreter,
        (1e9 / interpreter) / 320_000.0 * 100.0
    );
}
