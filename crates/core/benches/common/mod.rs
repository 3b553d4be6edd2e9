//! Shared by the benches: a realistic live MIDI byte stream, made from a real Standard MIDI
//! File the way a sequencer would send it down a DIN cable.
//!
//! - Tracks are merged; every channel event becomes wire bytes, with running status where
//!   consecutive statuses match. Meta events, SysEx and escapes are left out (a sequencer
//!   sending to a piano robot keeps the notes).
//! - MIDI clock (0xF8) runs at 24 per quarter note, on the file's own tempo map, and is sent
//!   the moment it is due, between the bytes of a message if need be, as real-time bytes are.
//! - Each byte takes 320 µs on the wire (31250 baud, 10 bits). A byte's time is when its stop
//!   bit ends, i.e. when a UART would hand it over. Bytes that fall due while the wire is busy
//!   queue behind it.
//!
//! The file is `../shared/midi/bach-bwv850-krueger.mid` beside the checkout (Bernd Krueger's
//! piano-midi.de performance, CC BY-SA 3.0 DE), or the path in `ORCH_BENCH_MIDI`. Without it,
//! a synthetic stream of the same kind is made, and the output says so.

// Each bench uses a different part of this module.
#![allow(dead_code)]

use std::path::PathBuf;

use midly::live::LiveEvent;
use midly::{MetaMessage, Smf, Timing, TrackEventKind};

/// One DIN MIDI byte on the wire: 10 bits at 31250 baud.
pub const DIN_BYTE_US: u64 = 320;
/// What a DIN line can carry: 3125 bytes a second.
pub const DIN_BYTES_PER_SEC: f64 = 1_000_000.0 / DIN_BYTE_US as f64;

/// A live byte stream with arrival times.
pub struct Stream {
    /// Where it came from, for the report.
    pub source: String,
    /// Whether it is the synthetic fallback.
    pub synthetic: bool,
    /// The bytes, in wire order.
    pub bytes: Vec<u8>,
    /// When each byte has fully arrived, in µs from the start.
    pub arrival_us: Vec<u64>,
    /// Channel messages in it.
    pub channel_messages: usize,
    /// Note-Ons with velocity above 0.
    pub note_ons: usize,
    /// Clock bytes in it.
    pub clocks: usize,
    /// Clock bytes sent between the bytes of a channel message.
    pub clocks_inside_messages: usize,
    /// Status bytes saved by running status.
    pub running_status_saved: usize,
}

impl Stream {
    /// The stream's length in µs (the arrival of its last byte).
    pub fn duration_us(&self) -> u64 {
        self.arrival_us.last().copied().unwrap_or(0)
    }

    /// One line describing the stream.
    pub fn describe(&self) -> String {
        let secs = self.duration_us() as f64 / 1e6;
        let busy = self.bytes.len() as f64 * DIN_BYTE_US as f64 / self.duration_us().max(1) as f64;
        format!(
            "{} bytes, {:.1} s of music: {} channel messages ({} note-ons, {} status bytes saved \
             by running status), {} clock bytes (0xF8, {} of them inside a message); the DIN \
             line is busy {:.1}% of the time",
            self.bytes.len(),
            secs,
            self.channel_messages,
            self.note_ons,
            self.running_status_saved,
            self.clocks,
            self.clocks_inside_messages,
            busy * 100.0,
        )
    }
}

/// The realistic stream: the real file if it can be read, otherwise the synthetic one.
pub fn realistic_stream() -> Stream {
    let path = std::env::var_os("ORCH_BENCH_MIDI")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../../shared/midi/bach-bwv850-krueger.mid")
        });
    let shown = path
        .canonicalize()
        .unwrap_or_else(|_| path.clone())
        .display()
        .to_string();
    match std::fs::read(&path) {
        Ok(raw) => match from_smf(&raw, &shown) {
            Ok(stream) => stream,
            Err(why) => synthetic(&format!("{shown} could not be used ({why})")),
        },
        Err(why) => synthetic(&format!("{shown} is missing ({why})")),
    }
}

/// A message due at a time, as wire bytes.
struct Due {
    at_us: u64,
    bytes: Vec<u8>,
}

fn from_smf(raw: &[u8], shown: &str) -> Result<Stream, String> {
    let smf = Smf::parse(raw).map_err(|e| e.to_string())?;
    // Merge the tracks by absolute tick; ties keep track order, then file order.
    let mut events = Vec::new();
    for (track_index, track) in smf.tracks.iter().enumerate() {
        let mut tick = 0u64;
        for (index, event) in track.iter().enumerate() {
            tick += event.delta.as_int() as u64;
            events.push((tick, track_index, index, event.kind));
        }
    }
    events.sort_by_key(|&(tick, track, index, _)| (tick, track, index));

    // Ticks to µs: metrical files follow their tempo map, SMPTE ones a fixed tick length.
    let (ticks_per_quarter, fixed_tick_us) = match smf.header.timing {
        Timing::Metrical(tpq) => (tpq.as_int() as f64, None),
        Timing::Timecode(fps, sub) => (
            // Clocks at 120 bpm for want of a tempo.
            500_000.0 / (1e6 / (fps.as_f32() as f64 * sub as f64)),
            Some(1e6 / (fps.as_f32() as f64 * sub as f64)),
        ),
    };
    let mut tempo_us = 500_000.0; // µs per quarter until a Set Tempo says otherwise
    let tick_us = |tempo: f64| fixed_tick_us.unwrap_or(tempo / ticks_per_quarter);
    let mut last_tick = 0u64;
    let mut last_us = 0.0f64;
    let mut clocks_us = Vec::new();
    let mut next_clock = 0u64; // index of the next clock: clock k is at tick k·tpq/24
    let mut messages = Vec::new();
    let mut running = None;
    let mut channel_messages = 0;
    let mut note_ons = 0;
    let mut saved = 0;
    let last_event_tick = events.last().map_or(0, |e| e.0);
    for (tick, _, _, kind) in events {
        // Clocks up to and including this tick, at the tempo in force.
        loop {
            let clock_tick = next_clock as f64 * ticks_per_quarter / 24.0;
            if clock_tick > tick as f64 || clock_tick > last_event_tick as f64 {
                break;
            }
            clocks_us.push((last_us + (clock_tick - last_tick as f64) * tick_us(tempo_us)) as u64);
            next_clock += 1;
        }
        let now_us = last_us + (tick - last_tick) as f64 * tick_us(tempo_us);
        last_us = now_us;
        last_tick = tick;
        match kind {
            TrackEventKind::Meta(MetaMessage::Tempo(t)) => tempo_us = t.as_int() as f64,
            TrackEventKind::Midi { channel, message } => {
                let mut bytes = Vec::with_capacity(3);
                let was = running;
                LiveEvent::Midi { channel, message }
                    .write_std_with_running_status(&mut running, &mut bytes)
                    .map_err(|e| e.to_string())?;
                if was == running {
                    saved += 1;
                }
                channel_messages += 1;
                if let midly::MidiMessage::NoteOn { vel, .. } = message {
                    if vel.as_int() > 0 {
                        note_ons += 1;
                    }
                }
                messages.push(Due {
                    at_us: now_us as u64,
                    bytes,
                });
            }
            _ => {}
        }
    }
    if messages.is_empty() {
        return Err("no channel events".into());
    }
    let mut stream = serialise(messages, clocks_us);
    stream.source = format!("{shown} (merged tracks, running status, clock at 24 ppq)");
    stream.channel_messages = channel_messages;
    stream.note_ons = note_ons;
    stream.running_status_saved = saved;
    Ok(stream)
}

/// Puts messages and clocks on a DIN wire, one byte every 320 µs. A clock goes out as soon as
/// it is due, even between the bytes of a message; a message goes out when it is due and the
/// wire is free.
fn serialise(messages: Vec<Due>, clocks_us: Vec<u64>) -> Stream {
    let mut bytes = Vec::new();
    let mut arrival_us = Vec::new();
    let mut inside = 0;
    let (mut m, mut c, mut sent_of_current) = (0usize, 0usize, 0usize);
    let mut now = 0u64; // when the wire is next free
    loop {
        let clock_due = clocks_us.get(c).copied();
        let msg_due = messages.get(m).map(|d| d.at_us);
        let mid_message = sent_of_current > 0;
        let byte = if clock_due.is_some_and(|t| t <= now) {
            c += 1;
            if mid_message {
                inside += 1;
            }
            0xF8
        } else if mid_message || msg_due.is_some_and(|t| t <= now) {
            let due = &messages[m];
            let b = due.bytes[sent_of_current];
            sent_of_current += 1;
            if sent_of_current == due.bytes.len() {
                sent_of_current = 0;
                m += 1;
            }
            b
        } else {
            match (clock_due, msg_due) {
                (None, None) => break,
                (a, b) => now = a.unwrap_or(u64::MAX).min(b.unwrap_or(u64::MAX)),
            }
            continue;
        };
        now += DIN_BYTE_US;
        bytes.push(byte);
        arrival_us.push(now);
    }
    let clocks = clocks_us.len();
    Stream {
        source: String::new(),
        synthetic: false,
        bytes,
        arrival_us,
        channel_messages: 0,
        note_ons: 0,
        clocks,
        clocks_inside_messages: inside,
        running_status_saved: 0,
    }
}

/// Two hands of piano at 120 bpm for about three minutes: a melody in eighths over chords,
/// with running status and the clock, from a fixed seed.
fn synthetic(why: &str) -> Stream {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut rand = |n: u64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed % n
    };
    let quarter_us = 500_000u64;
    let mut messages = Vec::new();
    let mut running = None;
    let (mut note_ons, mut saved) = (0, 0);
    let mut push = |at_us: u64, status: u8, note: u8, vel: u8, messages: &mut Vec<Due>| {
        let mut bytes = Vec::with_capacity(3);
        if running == Some(status) {
            saved += 1;
        } else {
            bytes.push(status);
            running = Some(status);
        }
        bytes.extend_from_slice(&[note, vel]);
        messages.push(Due { at_us, bytes });
    };
    let beats = 360u64;
    for beat in 0..beats {
        let t = beat * quarter_us;
        // A three-note chord each beat, released just before the next.
        let root = 36 + rand(24) as u8;
        for n in [root, root + 4, root + 7] {
            push(t, 0x90, n, 60 + rand(40) as u8, &mut messages);
            note_ons += 1;
        }
        // Two melody eighths, Note-Off as Note-On velocity 0.
        for half in 0..2 {
            let at = t + half * quarter_us / 2;
            let n = 60 + rand(30) as u8;
            push(at, 0x90, n, 70 + rand(50) as u8, &mut messages);
            note_ons += 1;
            push(at + quarter_us / 2 - 20_000, 0x90, n, 0, &mut messages);
        }
        for n in [root, root + 4, root + 7] {
            push(t + quarter_us - 10_000, 0x90, n, 0, &mut messages);
        }
    }
    // Every message is 0x90, so running status stays right after sorting by time.
    messages.sort_by_key(|d| d.at_us);
    let clocks_us = (0..beats * 24).map(|k| k * quarter_us / 24).collect();
    let channel_messages = messages.len();
    let mut stream = serialise(messages, clocks_us);
    stream.source = format!("SYNTHETIC stream (fallback: {why})");
    stream.synthetic = true;
    stream.channel_messages = channel_messages;
    stream.note_ons = note_ons;
    stream.running_status_saved = saved;
    stream
}
