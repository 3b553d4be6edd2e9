//! The invariants the `interpret` fuzz target checks, shared with the stable-Rust test
//! `crates/core/tests/fuzz_replay.rs`, which replays the corpus and the regressions with it.
//! Both use it from here (testkit's `fuzz-interpret` feature).
//!
//! An input is a 4-byte header and a MIDI byte stream:
//!
//! | header byte | meaning |
//! |---|---|
//! | 0 | flags: bit 0 Drop (else Fold), bit 1 sustain on, bit 2 some channels only, bit 3 `NotePool<16>` (else `NoteTable`), bit 4 guard off, bit 5 no watchdog, bit 6 no hold limit |
//! | 1 | channel mask seed; where the decoder check splits the input |
//! | 2 | `max_keys_down` = 1 + low nibble; `restrike_gap` = 8 ms × high nibble |
//! | 3 | `max_hold` = 5 + n ms; `min_press` = n mod 30 ms |
//!
//! Each stream byte's arrival time comes from a generator seeded by the header and stirred by
//! every byte: mostly bursts (same instant) and 320 µs wire gaps, sometimes up to 5 ms, 200 ms
//! or 6 s of silence. Every long gap also gets a bare `tick` half-way.
//!
//! What must hold, for any input (a violation panics):
//!
//! - the decoder gives the same messages, counters and SysEx data byte by byte as in two
//!   slices split anywhere; `bytes` counts every byte, `messages` every message but
//!   `SysExStart`; every defined real-time byte gives one message;
//! - the interpreter fed byte by byte gives the same frames, stats, counters and deadlines as
//!   fed a burst at a time; the boards show the frame after every flush;
//! - with the guard on: no finger down longer than `max_hold`, never more than
//!   `max_keys_down` fingers down, never a strike sooner than `restrike_gap` after a release
//!   (all read from the board writes and their times); `next_deadline` always moves on;
//! - after `all_off` and a flush every bit of every board is 0, and stays 0; the stats add up.

use orch_core::{
    ChannelMask, Config, Decoder, Duration, GuardConfig, HeldNotes, Instant, Interpreter, Message,
    NotePool, NoteTable, OutOfRange, Recording,
};

/// Checks every invariant on one input. Panics on a violation.
pub fn check(data: &[u8]) {
    check_decoder(data);
    let (header, stream) = split_header(data);
    let setup = Setup::from_header(header);
    if header[0] & 0x08 != 0 {
        check_interpreter::<NotePool<16>>(&setup, stream);
    } else {
        check_interpreter::<NoteTable>(&setup, stream);
    }
}

fn split_header(data: &[u8]) -> ([u8; 4], &[u8]) {
    let mut header = [0u8; 4];
    let n = data.len().min(4);
    header[..n].copy_from_slice(&data[..n]);
    (header, &data[n..])
}

// ---------------------------------------------------------------------------------------------
// Decoder

type Decoded = (Vec<Message>, orch_core::Counters, Vec<u8>);

fn decode_bytewise(data: &[u8]) -> Decoded {
    let mut d = Decoder::<8>::new();
    let mut out = Vec::new();
    for &b in data {
        out.extend(d.push(b));
    }
    (out, d.counters(), d.sysex_data().to_vec())
}

fn check_decoder(data: &[u8]) {
    let reference = decode_bytewise(data);
    let split = if data.len() < 2 {
        0
    } else {
        (data[1] as usize * 7 + data[data.len() - 1] as usize) % (data.len() + 1)
    };
    let mut d = Decoder::<8>::new();
    let mut out = Vec::new();
    d.push_slice(&data[..split], |m| out.push(m));
    d.push_slice(&data[split..], |m| out.push(m));
    let split_run = (out, d.counters(), d.sysex_data().to_vec());
    assert_eq!(split_run, reference, "decoder: split at {split} differs");

    let (messages, counters, _) = reference;
    assert_eq!(
        counters.bytes as usize,
        data.len(),
        "decoder: bytes counter"
    );
    let counted = messages
        .iter()
        .filter(|m| **m != Message::SysExStart)
        .count();
    assert_eq!(
        counters.messages as usize, counted,
        "decoder: messages counter"
    );
    let realtime = data
        .iter()
        .filter(|&&b| b >= 0xF8 && b != 0xF9 && b != 0xFD)
        .count();
    assert_eq!(
        messages.iter().filter(|m| m.is_realtime()).count(),
        realtime,
        "decoder: one message per real-time byte"
    );
    let data_bytes = data.iter().filter(|&&b| b < 0x80).count();
    assert!(counters.dropped as usize <= data_bytes, "decoder: dropped");
    let status_bytes = data.iter().filter(|&&b| (0x80..0xF8).contains(&b)).count();
    assert!(
        counters.abandoned as usize <= status_bytes,
        "decoder: abandoned"
    );
}

// ---------------------------------------------------------------------------------------------
// Interpreter

struct Setup {
    config: Config<4>,
    seed: u64,
}

impl Setup {
    fn from_header(h: [u8; 4]) -> Self {
        let flags = h[0];
        // The rest (`max_pulse`, with orch-core's `strike` feature) as by default: built
        // without that feature, there is no rest.
        #[allow(clippy::needless_update)]
        let guard = GuardConfig {
            enabled: flags & 0x10 == 0,
            max_hold: (flags & 0x40 == 0).then(|| Duration::from_millis(5 + h[3] as u32)),
            max_keys_down: 1 + (h[2] & 0x0F),
            restrike_gap: Duration::from_millis(8 * (h[2] >> 4) as u32),
            min_press: Duration::from_millis(h[3] as u32 % 30),
            watchdog: (flags & 0x20 == 0).then(|| Duration::from_secs(4)),
            late_limit: (flags & 0x08 == 0).then(|| Duration::from_millis(h[1] as u32 % 64)),
            // (Only where orch-core was built with its duty limit: the default has one then.)
            duty: (flags & 0x80 == 0 && GuardConfig::DEFAULT.duty.is_some()).then(|| {
                orch_core::DutyLimit {
                    window: Duration::from_millis(400),
                    max_on: Duration::from_millis(20 + h[1] as u32),
                }
            }),
            ..GuardConfig::DEFAULT
        };
        let channels = if flags & 0x04 != 0 {
            ChannelMask(u16::from_le_bytes([h[1], h[1].rotate_left(3)]))
        } else {
            ChannelMask::ALL
        };
        let config = Config {
            channels,
            out_of_range: if flags & 0x01 != 0 {
                OutOfRange::Drop
            } else {
                OutOfRange::Fold
            },
            sustain: flags & 0x02 != 0,
            overlap: if h[2] & 0x08 != 0 {
                orch_core::Overlap::Hold
            } else {
                orch_core::Overlap::Restrike
            },
            guard,
            ..Config::THESIS
        };
        Self {
            config,
            seed: u64::from_le_bytes([h[0], h[1], h[2], h[3], 0x4F, 0x52, 0x43, 0x48]),
        }
    }
}

/// When each byte arrives, in µs from the start.
fn arrival_times(seed: u64, stream: &[u8]) -> Vec<u64> {
    let mut state = seed;
    let mut t = 0u64;
    stream
        .iter()
        .map(|&b| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407 ^ b as u64);
            let r = state >> 33;
            t += match r % 16 {
                0..=7 => 0,
                8..=12 => 320,
                13 => r % 5_000,
                14 => r % 200_000,
                _ => r % 6_000_000,
            };
            t
        })
        .collect()
}

/// One interpreter, the boards it writes to, and what the boards have shown.
struct Robot<H: HeldNotes> {
    robot: Interpreter<4, 61, H>,
    boards: Recording<4>,
    /// For each board and bit: when it went down, if it is down.
    down_since: [[Option<u64>; 16]; 4],
    /// For each board and bit: when it last went up, if it ever did.
    up_since: [[Option<u64>; 16]; 4],
    shown: [u16; 4],
}

impl<H: HeldNotes> Robot<H> {
    fn new(config: Config<4>) -> Self {
        Self {
            robot: Interpreter::new(config).expect("the header makes only valid configs"),
            boards: Recording::new(),
            down_since: [[None; 16]; 4],
            up_since: [[None; 16]; 4],
            shown: [0; 4],
        }
    }

    /// Flushes at `t` and checks what the boards now show against the guard's rules.
    fn flush(&mut self, t: u64) {
        self.robot
            .flush(&mut self.boards)
            .expect("Recording never fails");
        self.boards.clear();
        let g = self.robot.config().guard;
        let mut down = 0;
        for board in 0..4 {
            let now = self.boards.outputs(board as u8);
            assert_eq!(
                now,
                self.robot.frame().outputs(board),
                "board {board} does not show the frame after a flush"
            );
            down += now.count_ones();
            let changed = now ^ self.shown[board];
            for bit in 0..16 {
                let on = now & (1 << bit) != 0;
                if changed & (1 << bit) != 0 {
                    if on {
                        if let (true, Some(up)) = (g.enabled, self.up_since[board][bit]) {
                            let rest = t - up;
                            assert!(
                                rest >= g.restrike_gap.as_micros() as u64,
                                "board {board} bit {bit}: struck at {t} µs, {rest} µs after its release (gap {:?})",
                                g.restrike_gap
                            );
                        }
                        self.down_since[board][bit] = Some(t);
                    } else {
                        self.down_since[board][bit] = None;
                        self.up_since[board][bit] = Some(t);
                    }
                }
            }
            self.shown[board] = now;
        }
        assert_eq!(
            self.robot.keys_down() as u32,
            down,
            "keys_down() disagrees with the boards"
        );
        if g.enabled {
            assert!(
                down <= g.max_keys_down as u32,
                "{down} fingers down at {t} µs, budget {}",
                g.max_keys_down
            );
        }
        self.check_hold(t);
        let s = self.robot.stats();
        let accounted = s.played + s.folded + s.dropped();
        assert!(
            s.note_ons >= accounted && s.note_ons - accounted <= 61,
            "stats: {s:?}"
        );
    }

    /// No finger on the boards has been down longer than the hold limit at `t`.
    fn check_hold(&self, t: u64) {
        let g = self.robot.config().guard;
        let (true, Some(hold)) = (g.enabled, g.max_hold) else {
            return;
        };
        for (board, bits) in self.down_since.iter().enumerate() {
            for (bit, since) in bits.iter().enumerate() {
                if let Some(since) = since {
                    let held = t - since;
                    assert!(
                        held <= hold.as_micros() as u64,
                        "board {board} bit {bit}: down since {since} µs, {held} µs at {t} µs (limit {hold:?})"
                    );
                }
            }
        }
    }

    /// Ticks at every deadline up to `t`. The deadline must move on: it may stay at the same
    /// instant for a tick or two (a strike whose `min_press` is 0 is released by the next tick
    /// at the same instant), never for ever.
    fn run_until(&mut self, t: u64) {
        let mut same_instant = 0;
        let mut previous = None;
        while let Some(d) = self.robot.next_deadline() {
            let d = d.as_micros();
            if d > t {
                break;
            }
            assert!(
                previous.is_none_or(|p| d >= p),
                "next_deadline() went back from {previous:?} to {d} µs"
            );
            same_instant = if previous == Some(d) {
                same_instant + 1
            } else {
                0
            };
            assert!(
                same_instant < 4,
                "next_deadline() stays at {d} µs after ticking it"
            );
            previous = Some(d);
            self.robot.tick(Instant::from_micros(d));
            self.flush(d);
        }
    }

    fn tick(&mut self, t: u64) {
        self.run_until(t);
        self.robot.tick(Instant::from_micros(t));
        self.flush(t);
    }
}

fn same<H: HeldNotes>(a: &Robot<H>, b: &Robot<H>, t: u64) {
    assert_eq!(a.robot.frame(), b.robot.frame(), "frames differ at {t} µs");
    assert_eq!(a.shown, b.shown, "boards differ at {t} µs");
    assert_eq!(a.robot.stats(), b.robot.stats(), "stats differ at {t} µs");
    assert_eq!(
        a.robot.counters(),
        b.robot.counters(),
        "counters differ at {t} µs"
    );
    assert_eq!(
        a.robot.next_deadline(),
        b.robot.next_deadline(),
        "deadlines differ at {t} µs"
    );
}

fn check_interpreter<H: HeldNotes>(setup: &Setup, stream: &[u8]) {
    let times = arrival_times(setup.seed, stream);
    // `bytewise` gets one `feed` per byte; `bursts` one `feed_slice` per burst of bytes that
    // arrive at the same instant. Both flush after each burst.
    let mut bytewise = Robot::<H>::new(setup.config);
    let mut bursts = Robot::<H>::new(setup.config);
    let mut last = 0u64;
    let mut i = 0;
    while i < stream.len() {
        let t = times[i];
        let mut j = i;
        while j < stream.len() && times[j] == t {
            j += 1;
        }
        if t - last > 1_000 {
            let mid = last + (t - last) / 2;
            bytewise.tick(mid);
            bursts.tick(mid);
            same(&bytewise, &bursts, mid);
        }
        bytewise.run_until(t);
        bursts.run_until(t);
        for &b in &stream[i..j] {
            bytewise.robot.feed(b, Instant::from_micros(t));
        }
        bursts
            .robot
            .feed_slice(&stream[i..j], Instant::from_micros(t));
        bytewise.flush(t);
        bursts.flush(t);
        same(&bytewise, &bursts, t);
        last = t;
        i = j;
    }
    assert_eq!(bytewise.robot.counters().bytes as usize, stream.len());

    for mut robot in [bytewise, bursts] {
        // Let every timer run out, then switch everything off.
        let end = last + 3_600_000_000;
        robot.run_until(end);
        robot.robot.all_off(Instant::from_micros(end));
        robot.flush(end);
        assert_eq!(robot.shown, [0; 4], "boards after all_off");
        assert_eq!(robot.robot.frame().all(), &[0; 4], "frame after all_off");
        assert_eq!(robot.robot.keys_down(), 0);
        let s = *robot.robot.stats();
        assert_eq!(
            s.note_ons,
            s.played + s.folded + s.dropped(),
            "stats do not add up: {s:?}"
        );
        // Nothing comes back on by itself.
        robot.tick(end + 3_600_000_000);
        assert_eq!(robot.shown, [0; 4], "a finger came back after all_off");
    }
}
