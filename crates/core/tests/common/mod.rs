//! Helpers shared by the orch-core integration tests: message builders, a decoder driver, a
//! test rig that runs an interpreter against the `Recording` double and keeps the timeline of
//! every finger edge, and proptest strategies for MIDI-ish byte streams.
//!
//! Each test file uses a different part of this module.
#![allow(dead_code)]

use orch_core::{
    Channel, Config, Counters, Decoder, GuardConfig, HeldNotes, Instant, Interpreter, Message,
    Note, NoteTable, Recording, Velocity, U7,
};
use proptest::prelude::*;

// ---------------------------------------------------------------------------------------------
// Values and messages

pub fn ch(c: u8) -> Channel {
    Channel::new(c).expect("channel 0..=15")
}

pub fn note_on(channel: u8, note: u8, velocity: u8) -> Message {
    Message::NoteOn {
        channel: ch(channel),
        note: Note::new(note).unwrap(),
        velocity: Velocity::new(velocity).unwrap(),
    }
}

pub fn note_off(channel: u8, note: u8, velocity: u8) -> Message {
    Message::NoteOff {
        channel: ch(channel),
        note: Note::new(note).unwrap(),
        velocity: Velocity::new(velocity).unwrap(),
    }
}

pub fn cc(channel: u8, controller: u8, value: u8) -> Message {
    Message::ControlChange {
        channel: ch(channel),
        controller: U7::new(controller).unwrap(),
        value: U7::new(value).unwrap(),
    }
}

pub fn ms(millis: u64) -> Instant {
    Instant::from_millis(millis)
}

pub fn us(micros: u64) -> Instant {
    Instant::from_micros(micros)
}

/// The real-time bytes that emit a message, with the message.
pub const REALTIME: [(u8, Message); 6] = [
    (0xF8, Message::Clock),
    (0xFA, Message::Start),
    (0xFB, Message::Continue),
    (0xFC, Message::Stop),
    (0xFE, Message::ActiveSensing),
    (0xFF, Message::Reset),
];

/// The undefined real-time bytes: ignored, with no other effect.
pub const UNDEFINED_REALTIME: [u8; 2] = [0xF9, 0xFD];

/// What a real-time byte emits: `Some(message)`, or `None` for 0xF9 / 0xFD.
pub fn realtime_message(byte: u8) -> Option<Message> {
    REALTIME.iter().find(|(b, _)| *b == byte).map(|(_, m)| *m)
}

// ---------------------------------------------------------------------------------------------
// Decoding

/// Decodes `bytes` one `push` at a time; returns every message (SysExStart included) and the
/// counters.
pub fn decode(bytes: &[u8]) -> (Vec<Message>, Counters) {
    let mut d = Decoder::<0>::new();
    let mut out = Vec::new();
    for &b in bytes {
        out.extend(d.push(b));
    }
    (out, d.counters())
}

/// Decodes `bytes`, returning the messages each byte produced (one list per byte).
pub fn decode_per_byte(bytes: &[u8]) -> (Vec<Vec<Message>>, Counters) {
    let mut d = Decoder::<0>::new();
    let per_byte = bytes.iter().map(|&b| d.push(b).collect()).collect();
    (per_byte, d.counters())
}

/// The messages a `Decoder::<SYSEX>` emits for `bytes` and its `sysex_data()` after them.
pub fn decode_with_sysex<const SYSEX: usize>(bytes: &[u8]) -> (Vec<Message>, Counters, Vec<u8>) {
    let mut d = Decoder::<SYSEX>::new();
    let mut out = Vec::new();
    d.push_slice(bytes, |m| out.push(m));
    (out, d.counters(), d.sysex_data().to_vec())
}

/// Messages that count in `Counters::messages` (all but `SysExStart`).
pub fn counted(messages: &[Message]) -> u32 {
    messages
        .iter()
        .filter(|m| **m != Message::SysExStart)
        .count() as u32
}

// ---------------------------------------------------------------------------------------------
// The interpreter rig

/// A finger going down or up, as seen on the boards (after a flush).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    pub t: Instant,
    pub board: u8,
    pub bit: u8,
    pub on: bool,
}

/// An interpreter, the boards it writes to, and every edge the boards saw, with its time.
///
/// Every operation takes the time, flushes, and records the edges at that time, so the
/// timeline is exact to the operation.
pub struct Rig<H: HeldNotes = NoteTable> {
    pub robot: Interpreter<4, 61, H>,
    pub boards: Recording<64>,
    pub timeline: Vec<Edge>,
    /// The outputs after the latest flush.
    pub last: [u16; 4],
    /// The time of the latest operation.
    pub now: Instant,
    /// Board writes made so far.
    pub writes: usize,
    /// The outputs after each flush that changed any, with its time: one entry a flush, where
    /// `timeline` has one a pin (and several flushes may share an instant).
    pub states: Vec<(Instant, [u16; 4])>,
}

impl Rig<NoteTable> {
    pub fn new(config: Config<4>) -> Self {
        Self::with_store(config)
    }

    pub fn thesis() -> Self {
        Self::new(Config::THESIS)
    }

    /// The thesis's robot with `overlap = hold`: a second note on a key that is down joins it.
    pub fn holding() -> Self {
        Self::new(Config {
            overlap: orch_core::Overlap::Hold,
            ..Config::THESIS
        })
    }

    /// The thesis's robot with no late limit: every re-strike waits for its gap however long.
    pub fn patient() -> Self {
        Self::with_guard(GuardConfig {
            late_limit: None,
            ..GuardConfig::DEFAULT
        })
    }

    pub fn with_guard(guard: GuardConfig) -> Self {
        Self::new(Config {
            guard,
            ..Config::THESIS
        })
    }
}

impl<H: HeldNotes> Rig<H> {
    /// A rig whose interpreter keeps held notes in `H`.
    pub fn with_store(config: Config<4>) -> Self {
        Self {
            robot: Interpreter::new(config).expect("valid config"),
            boards: Recording::new(),
            timeline: Vec::new(),
            last: [0; 4],
            now: Instant::ZERO,
            writes: 0,
            states: Vec::new(),
        }
    }

    /// Flushes at `t` and records the edges. Also checks that the boards show the frame.
    pub fn flush(&mut self, t: Instant) {
        self.now = self.now.max(t);
        let n = self
            .robot
            .flush(&mut self.boards)
            .expect("recording never fails");
        self.writes += n as usize;
        for board in 0..4u8 {
            let now = self.boards.outputs(board);
            assert_eq!(
                now,
                self.robot.frame().outputs(board as usize),
                "board {board} does not show the frame after a flush"
            );
            let was = self.last[board as usize];
            let changed = now ^ was;
            for bit in 0..16u8 {
                if changed & (1 << bit) != 0 {
                    self.timeline.push(Edge {
                        t: self.now,
                        board,
                        bit,
                        on: now & (1 << bit) != 0,
                    });
                }
            }
            self.last[board as usize] = now;
        }
        self.boards.clear();
        if self
            .states
            .last()
            .map_or(self.last != [0; 4], |s| s.1 != self.last)
        {
            self.states.push((self.now, self.last));
        }
    }

    /// Feeds `bytes` arriving at `t`, first running every deadline that falls due before `t`.
    pub fn feed(&mut self, bytes: &[u8], t: Instant) {
        self.run_until(t);
        self.robot.feed_slice(bytes, t);
        self.flush(t);
    }

    /// Hands a decoded message over at `t`, first running every deadline before `t`.
    pub fn handle(&mut self, message: Message, t: Instant) {
        self.run_until(t);
        self.robot.handle(message, t);
        self.flush(t);
    }

    pub fn tick(&mut self, t: Instant) {
        self.robot.tick(t);
        self.flush(t);
    }

    pub fn all_off(&mut self, t: Instant) {
        self.robot.all_off(t);
        self.flush(t);
    }

    /// Ticks at every `next_deadline()` up to and including `t` (not at `t` itself), as a
    /// firmware main loop would.
    pub fn run_until(&mut self, t: Instant) {
        let mut guard = 0;
        while let Some(d) = self.robot.next_deadline() {
            if d > t {
                break;
            }
            let before = self.now;
            self.tick(d);
            guard += 1;
            assert!(
                guard < 10_000,
                "next_deadline() keeps answering {d:?} (clock {before:?}) without progress"
            );
        }
    }

    /// Whether the finger of note-key `key` (0 = note 36) is down on the boards, thesis layout.
    pub fn key_on_board(&self, key: u8) -> bool {
        let (board, bit) = thesis_finger(key);
        self.last[board as usize] & (1 << bit) != 0
    }

    /// Whether `note` (in range) is down on the boards, thesis layout.
    pub fn note_down(&self, note: u8) -> bool {
        self.key_on_board(note - 36)
    }

    /// Keys down on the boards now.
    pub fn fingers_down(&self) -> u32 {
        self.last.iter().map(|w| w.count_ones()).sum()
    }

    /// The edges of the finger of `note`, thesis layout.
    pub fn edges_of(&self, note: u8) -> Vec<(Instant, bool)> {
        let (board, bit) = thesis_finger(note - 36);
        self.timeline
            .iter()
            .filter(|e| e.board == board && e.bit == bit)
            .map(|e| (e.t, e.on))
            .collect()
    }
}

/// The thesis layout, from the spec: key k on board k / 16, bit k % 16.
pub fn thesis_finger(key: u8) -> (u8, u8) {
    (key / 16, key % 16)
}

/// The spec's folding: below 36 +12 until in range; above 96 −12 until in range.
pub fn fold(note: u8) -> u8 {
    let mut n = note;
    while n < 36 {
        n += 12;
    }
    while n > 96 {
        n -= 12;
    }
    n
}

// ---------------------------------------------------------------------------------------------
// Timeline checks

/// Every finger that went down at `t1` went up by `t1 + limit` (or, if still down at `end`,
/// `end - t1 <= limit`).
pub fn assert_no_hold_longer_than(timeline: &[Edge], limit_us: u64, end: Instant) {
    let mut down_since: std::collections::HashMap<(u8, u8), Instant> = Default::default();
    for e in timeline {
        if e.on {
            down_since.insert((e.board, e.bit), e.t);
        } else if let Some(t1) = down_since.remove(&(e.board, e.bit)) {
            let held = e.t.saturating_since(t1);
            assert!(
                held <= limit_us,
                "board {} bit {} held {held} µs (from {t1:?} to {:?}), limit {limit_us} µs",
                e.board,
                e.bit,
                e.t
            );
        }
    }
    for ((board, bit), t1) in down_since {
        let held = end.saturating_since(t1);
        assert!(
            held <= limit_us,
            "board {board} bit {bit} still down at {end:?}, since {t1:?}: {held} µs > {limit_us} µs"
        );
    }
}

/// Every finger that went up at `t0` stayed up until at least `t0 + gap`.
pub fn assert_restrike_gap(timeline: &[Edge], gap_us: u64) {
    let mut up_since: std::collections::HashMap<(u8, u8), Instant> = Default::default();
    for e in timeline {
        if !e.on {
            up_since.insert((e.board, e.bit), e.t);
        } else if let Some(t0) = up_since.get(&(e.board, e.bit)) {
            let rest = e.t.saturating_since(*t0);
            assert!(
                rest >= gap_us,
                "board {} bit {} struck again {rest} µs after its release at {t0:?} (gap {gap_us} µs)",
                e.board,
                e.bit
            );
        }
    }
}

/// The most fingers down at once, looking at the state after each flush time.
pub fn max_fingers_down(timeline: &[Edge]) -> u32 {
    let mut state = [0u16; 4];
    let mut most = 0;
    let mut i = 0;
    while i < timeline.len() {
        let t = timeline[i].t;
        while i < timeline.len() && timeline[i].t == t {
            let e = timeline[i];
            if e.on {
                state[e.board as usize] |= 1 << e.bit;
            } else {
                state[e.board as usize] &= !(1 << e.bit);
            }
            i += 1;
        }
        most = most.max(state.iter().map(|w| w.count_ones()).sum());
    }
    most
}

// ---------------------------------------------------------------------------------------------
// Strategies

/// One byte, biased toward what makes MIDI streams interesting: status bytes of every kind,
/// real-time bytes, notes in and around the key range.
pub fn midi_byte() -> impl Strategy<Value = u8> {
    prop_oneof![
        4 => any::<u8>(),
        3 => 0u8..0x80,
        2 => 0x80u8..=0xEF,
        1 => 0xF0u8..=0xF7,
        1 => 0xF8u8..=0xFF,
    ]
}

/// Any byte stream, biased as [`midi_byte`].
pub fn byte_stream(max: usize) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(midi_byte(), 0..max)
}

/// A piece of a MIDI stream that makes the interpreter do things: notes on and off on a few
/// channels (with and without running status), the controllers it acts on, real-time bytes,
/// SysEx, and some plain noise.
pub fn musical_chunk() -> impl Strategy<Value = Vec<u8>> {
    let channel = prop_oneof![4 => 0u8..3, 1 => 0u8..16];
    let note = prop_oneof![6 => 34u8..100, 1 => any::<u8>().prop_map(|n| n & 0x7F)];
    let velocity = prop_oneof![4 => 1u8..128, 1 => Just(0u8)];
    prop_oneof![
        6 => (channel.clone(), note.clone(), velocity).prop_map(|(c, n, v)| vec![0x90 | c, n, v]),
        4 => (channel.clone(), note.clone()).prop_map(|(c, n)| vec![0x80 | c, n, 0x40]),
        // Running status: just the data bytes.
        3 => (note.clone(), 0u8..128).prop_map(|(n, v)| vec![n, v]),
        1 => (channel.clone(), prop::sample::select(vec![64u8, 120, 121, 123, 127, 7]), 0u8..128)
            .prop_map(|(c, k, v)| vec![0xB0 | c, k, v]),
        2 => prop::sample::select(vec![0xF8u8, 0xFE, 0xFF, 0xF9, 0xFA, 0xFC]).prop_map(|b| vec![b]),
        1 => prop::collection::vec(0u8..0x80, 0..6).prop_map(|mut d| {
            d.insert(0, 0xF0);
            d.push(0xF7);
            d
        }),
        1 => prop::collection::vec(midi_byte(), 1..4),
    ]
}

/// Time between two chunks, in µs: often none, mostly short, sometimes long silences.
pub fn gap_us() -> impl Strategy<Value = u64> {
    prop_oneof![
        3 => Just(0u64),
        4 => 0u64..2_000,
        4 => 0u64..120_000,
        1 => 0u64..6_000_000,
    ]
}

/// A timed stream: chunks with the time gap before each.
pub fn timed_stream(max_chunks: usize) -> impl Strategy<Value = Vec<(u64, Vec<u8>)>> {
    prop::collection::vec((gap_us(), musical_chunk()), 0..max_chunks)
}

/// One step of a timed run: after `gap` µs, feed `bytes` (or only tick, if `None`).
#[derive(Clone, Debug)]
pub struct Step {
    pub gap: u64,
    pub bytes: Option<Vec<u8>>,
}

/// Timed steps: mostly bytes, sometimes a bare tick at an arbitrary time.
pub fn timed_steps(max: usize) -> impl Strategy<Value = Vec<Step>> {
    let step = (gap_us(), prop::option::weighted(0.85, musical_chunk()))
        .prop_map(|(gap, bytes)| Step { gap, bytes });
    prop::collection::vec(step, 0..max)
}

/// Runs `steps` through `rig` from its current time: deadlines are ticked as they fall due
/// (`Rig::feed` does it before every feed), bare ticks happen where the steps say.
/// Calls `check` after every step. Returns the time of the last step.
pub fn run_steps<H: HeldNotes>(
    rig: &mut Rig<H>,
    steps: &[Step],
    mut check: impl FnMut(&Rig<H>),
) -> Instant {
    let mut t = rig.now;
    for step in steps {
        t = Instant::from_micros(t.as_micros() + step.gap);
        match &step.bytes {
            Some(bytes) => rig.feed(bytes, t),
            None => {
                rig.run_until(t);
                rig.tick(t);
            }
        }
        check(rig);
    }
    t
}

/// A configuration: any key policy, sustain on or off, all channels or some, and a guard with
/// limits drawn around the defaults (short enough to fire within a test).
pub fn any_config() -> impl Strategy<Value = Config<4>> {
    (
        any::<bool>(),
        any::<bool>(),
        prop_oneof![3 => Just(0xFFFFu16), 1 => any::<u16>()],
        guard(),
        any::<bool>(),
        dynamics(),
    )
        .prop_map(|(drop, sustain, mask, guard, hold, dynamics)| {
            #[cfg_attr(not(feature = "dynamics"), allow(unused_mut))]
            let mut config = Config {
                overlap: if hold {
                    orch_core::Overlap::Hold
                } else {
                    orch_core::Overlap::Restrike
                },
                out_of_range: if drop {
                    orch_core::OutOfRange::Drop
                } else {
                    orch_core::OutOfRange::Fold
                },
                sustain,
                channels: orch_core::ChannelMask(mask),
                guard,
                ..Config::THESIS
            };
            #[cfg(feature = "dynamics")]
            {
                config.dynamics = dynamics;
            }
            #[cfg(not(feature = "dynamics"))]
            let _ = dynamics;
            fit_strike(config, guard.max_hold)
        })
}

/// Whether every key of `config` is on/off (always, without the `dynamics` feature).
pub fn is_on_off(config: &Config<4>) -> bool {
    #[cfg(feature = "dynamics")]
    return config.dynamics.is_on_off();
    #[cfg(not(feature = "dynamics"))]
    return {
        let _ = config;
        true
    };
}

/// On/off keys (as without dynamics), the PWM defaults, or a curve of its own for every key
/// (drawn from a seed: softest 1..=4095, loudest at or above it, hold at or below it), with a
/// strike time of 1..60 ms.
pub fn dynamics() -> impl Strategy<Value = orch_core::Dynamics> {
    use orch_core::{Duration, Duty, Dynamics, Touch};
    (0u8..3, 1u32..60, any::<u64>()).prop_map(|(kind, strike, seed)| {
        let mut d = match kind {
            0 => Dynamics::ON_OFF,
            _ => Dynamics::PWM,
        };
        d.strike = Duration::from_millis(strike);
        if kind == 2 {
            let mut x = seed | 1;
            let mut next = |n: u64| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x % n
            };
            for t in d.keys.iter_mut() {
                let softest = 1 + next(4095) as u16;
                let loudest = softest + next(4096 - softest as u64) as u16;
                let hold = next(softest as u64 + 1) as u16;
                *t = Touch {
                    softest: Duty::new(softest).unwrap(),
                    loudest: Duty::new(loudest).unwrap(),
                    hold: Duty::new(hold).unwrap(),
                };
            }
        }
        d
    })
}

/// `config` with its strike time cut to `max_hold`, as a valid configuration needs.
#[cfg_attr(not(feature = "dynamics"), allow(unused_mut))]
pub fn fit_strike(mut config: Config<4>, max_hold: Option<orch_core::Duration>) -> Config<4> {
    #[cfg(feature = "dynamics")]
    if let Some(h) = max_hold {
        config.dynamics.strike = config.dynamics.strike.min(h);
    }
    let _ = max_hold;
    config
}

/// A guard, on, with limits short enough to fire in a test.
pub fn guard() -> impl Strategy<Value = GuardConfig> {
    use orch_core::Duration;
    (
        prop::option::weighted(0.9, 1u32..400),
        1u8..=16,
        prop_oneof![1 => Just(0u32), 3 => 1u32..100],
        0u32..40,
        prop::option::weighted(0.8, 100u32..5_000),
        prop::option::weighted(0.5, 0u32..80),
        prop::option::weighted(0.5, (1u32..300, 1u32..=100)),
    )
        .prop_map(
            |(hold, keys, gap, press, watchdog, late, duty)| GuardConfig {
                enabled: true,
                max_hold: hold.map(Duration::from_millis),
                max_keys_down: keys,
                restrike_gap: Duration::from_millis(gap),
                min_press: Duration::from_millis(press),
                watchdog: watchdog.map(Duration::from_millis),
                late_limit: late.map(Duration::from_millis),
                // max_on = window × percent / 100.
                duty: duty.filter(|_| GuardConfig::DEFAULT.duty.is_some()).map(
                    |(window, percent)| orch_core::DutyLimit {
                        window: Duration::from_millis(window),
                        max_on: Duration::from_micros((window * 10 * percent).max(1)),
                    },
                ),
                #[cfg(feature = "strike")]
                max_pulse: GuardConfig::DEFAULT.max_pulse,
            },
        )
}
