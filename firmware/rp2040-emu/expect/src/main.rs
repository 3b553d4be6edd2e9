//! orch-core on the host, run as firmware/rp2040's interpreter loop runs it, fed what the
//! Pico emulator fed the firmware: the board writes the firmware must make.
//!
//! - `orch-rp2040-expect` reads inputs from standard input, one a line, in time order:
//!   `din T B` (a DIN byte B at T µs), `usb T B1 [B2 [B3]]` (the MIDI bytes of one USB-MIDI
//!   event packet at T µs), `end T` (run the guard's timers up to T µs). It prints every
//!   board write, one a line: `write T BOARD OUTPUTS` (µs, 0..4, the 16 outputs), then
//!   `outputs O0 O1 O2 O3` (the final frame). Numbers are decimal, or hex with `0x`.
//! - `orch-rp2040-expect pca9685` does the same for the firmware's `pca9685` build: the
//!   settings in `firmware/rp2040-robot` (a crate both depend on, so both run the same ones:
//!   five PCA9685 boards, a piano played with strike and hold and a drum kit on channel 10
//!   played with pulses), flushed with `flush_duties`; it prints every `write_duties` as
//!   `duties T BOARD D0 .. D15` (µs, 0..5, each channel's duty 0..=4095), then
//!   `final BOARD D0 .. D15` for each board and `outputs O0 .. O4`.
//! - `orch-rp2040-expect smf FILE` prints a Standard MIDI File's channel messages as timed
//!   wire bytes, `T B` a line (µs from the start), in time order, with the tempo map.
//!
//! As in the firmware: DIN bytes go through the interpreter's own decoder; each USB-MIDI event
//! through a decoder of its own; before each input the guard's timers due by then run at their
//! own deadlines (each flushed apart: the firmware wakes at each); after each input one flush.

use std::io::{BufRead, Write};

use orch_core::{BoardId, Decoder, Duty, FingerBoards, HeldNotes, Instant, Interpreter};

/// The firmware's settings for its `pca9685` build.
use orch_rp2040_robot as robot;

/// Board writes with the time they were made.
struct Recorder<'a, W: Write> {
    now_us: u64,
    out: &'a mut W,
}

impl<W: Write> FingerBoards for Recorder<'_, W> {
    type Error = std::io::Error;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> std::io::Result<()> {
        writeln!(
            self.out,
            "write {} {} {}",
            self.now_us, board.index, outputs
        )
    }
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> std::io::Result<()> {
        write!(self.out, "duties {} {}", self.now_us, board.index)?;
        for d in duties {
            write!(self.out, " {}", d.get())?;
        }
        writeln!(self.out)
    }
}

/// The firmware's interpreter loop, on the host: `B` boards, `K` outputs.
struct Loop<'a, W: Write, const B: usize, const K: usize, H: HeldNotes> {
    robot: Interpreter<B, K, H>,
    usb: Decoder,
    boards: Recorder<'a, W>,
    /// PWM boards: flush with `flush_duties`.
    pwm: bool,
}

impl<W: Write, const B: usize, const K: usize, H: HeldNotes> Loop<'_, W, B, K, H> {
    fn advance(&mut self, at: u64) -> std::io::Result<()> {
        while let Some(d) = self.robot.next_deadline().filter(|d| d.as_micros() <= at) {
            self.robot.tick(d);
            self.flush(d.as_micros())?;
        }
        Ok(())
    }

    fn flush(&mut self, at: u64) -> std::io::Result<()> {
        self.boards.now_us = at;
        if self.pwm {
            self.robot.flush_duties(&mut self.boards)
        } else {
            self.robot.flush(&mut self.boards)
        }
        .map(drop)
        .map_err(|e| e.error)
    }

    fn line(&mut self, line: &str) -> Result<(), String> {
        let mut words = line.split_whitespace();
        let Some(kind) = words.next() else {
            return Ok(());
        };
        let nums: Vec<u64> = words.map(number).collect::<Result<_, _>>()?;
        let (&at, bytes) = nums.split_first().ok_or("a time after the kind")?;
        let io = |e: std::io::Error| e.to_string();
        self.advance(at).map_err(io)?;
        match (kind, bytes) {
            ("din", &[b]) => {
                self.robot.feed(
                    u8::try_from(b).map_err(|e| e.to_string())?,
                    Instant::from_micros(at),
                );
            }
            ("usb", b) if (1..=3).contains(&b.len()) => {
                for &b in b {
                    let b = u8::try_from(b).map_err(|e| e.to_string())?;
                    for m in self.usb.push(b) {
                        self.robot.handle(m, Instant::from_micros(at));
                    }
                }
            }
            ("end", []) => return Ok(()),
            _ => return Err(format!("not an input: {line:?}")),
        }
        self.flush(at).map_err(io)
    }
}

fn number(s: &str) -> Result<u64, String> {
    match s.strip_prefix("0x") {
        Some(h) => u64::from_str_radix(h, 16),
        None => s.parse(),
    }
    .map_err(|e| format!("{s:?}: {e}"))
}

/// A Standard MIDI File's channel messages as timed wire bytes (each message with its status
/// byte), in time order, with the tempo map: the ATmega16 tests' reading.
fn smf_to_wire(data: &[u8]) -> Result<Vec<(u64, u8)>, String> {
    use midly::{live::LiveEvent, MetaMessage, Smf, Timing, TrackEventKind};
    let smf = Smf::parse(data).map_err(|e| e.to_string())?;
    let ppq = match smf.header.timing {
        Timing::Metrical(t) => u64::from(t.as_int()),
        Timing::Timecode(..) => return Err("timecode files are not supported".into()),
    };
    let mut events = Vec::new();
    for (ti, track) in smf.tracks.iter().enumerate() {
        let mut tick = 0u64;
        for (ei, ev) in track.iter().enumerate() {
            tick += u64::from(ev.delta.as_int());
            events.push((tick, ti, ei, ev.kind));
        }
    }
    events.sort_by_key(|e| (e.0, e.1, e.2));
    let (mut tempo, mut last_tick, mut us) = (500_000u64, 0u64, 0u64);
    let mut out = Vec::new();
    for (tick, _, _, kind) in events {
        us += (tick - last_tick) * tempo / ppq;
        last_tick = tick;
        match kind {
            TrackEventKind::Meta(MetaMessage::Tempo(t)) => tempo = u64::from(t.as_int()),
            TrackEventKind::Midi { channel, message } => {
                let mut buf = Vec::new();
                LiveEvent::Midi { channel, message }
                    .write_std(&mut buf)
                    .map_err(|e| e.to_string())?;
                out.extend(buf.into_iter().map(|b| (us, b)));
            }
            _ => {}
        }
    }
    Ok(out)
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    if let [cmd, file] = &args[..] {
        if cmd != "smf" {
            return Err(format!("unknown command {cmd:?}"));
        }
        let data = std::fs::read(file).map_err(|e| format!("{file}: {e}"))?;
        for (t, b) in smf_to_wire(&data)? {
            writeln!(out, "{t} {b}").map_err(|e| e.to_string())?;
        }
        return out.flush().map_err(|e| e.to_string());
    }
    let pwm = match &args[..] {
        [] => false,
        [kind] if kind == "pca9685" => true,
        _ => {
            return Err(
                "usage: orch-rp2040-expect [pca9685 | smf FILE] (inputs on standard input)".into(),
            )
        }
    };
    let input = std::io::stdin().lock();
    if pwm {
        let robot = robot::Robot::new(robot::PCA9685).map_err(|e| e.to_string())?;
        run_loop(robot, true, input, &mut out)?;
    } else {
        run_loop(Interpreter::thesis(), false, input, &mut out)?;
    }
    out.flush().map_err(|e| e.to_string())
}

/// Runs `robot` on the inputs, then prints the final duties (PWM boards) and outputs.
fn run_loop<W: Write, const B: usize, const K: usize, H: HeldNotes>(
    robot: Interpreter<B, K, H>,
    pwm: bool,
    input: impl BufRead,
    out: &mut W,
) -> Result<(), String> {
    let mut l = Loop {
        pwm,
        robot,
        usb: Decoder::new(),
        boards: Recorder { now_us: 0, out },
    };
    for line in input.lines() {
        l.line(&line.map_err(|e| e.to_string())?)?;
    }
    let io = |e: std::io::Error| e.to_string();
    if pwm {
        for (b, duties) in l.robot.duties().iter().enumerate() {
            write!(l.boards.out, "final {b}").map_err(io)?;
            for d in duties {
                write!(l.boards.out, " {}", d.get()).map_err(io)?;
            }
            writeln!(l.boards.out).map_err(io)?;
        }
    }
    write!(l.boards.out, "outputs").map_err(io)?;
    for i in 0..B {
        write!(l.boards.out, " {}", l.robot.frame().outputs(i)).map_err(io)?;
    }
    writeln!(l.boards.out).map_err(io)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("orch-rp2040-expect: {e}");
        std::process::exit(1);
    }
}
