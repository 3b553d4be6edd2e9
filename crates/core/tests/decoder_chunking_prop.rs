//! Guards: the decoder's output depends only on the bytes, never on how they were handed over
//! (one `push` at a time, one `push_slice`, or slices split anywhere), and its counters add up
//! (`bytes` is every byte fed; `messages` is every message emitted except `SysExStart`).
//! Also checks it against a plain model written straight from the spec's rules.

mod common;

use common::{byte_stream, counted};
use orch_core::{Counters, Decoder, Message, Note, Velocity, U14, U7};
use proptest::prelude::*;

type Run = (Vec<Message>, Counters, Vec<u8>);

fn byte_by_byte(bytes: &[u8]) -> Run {
    let mut d = Decoder::<6>::new();
    let mut out = Vec::new();
    for &b in bytes {
        out.extend(d.push(b));
    }
    (out, d.counters(), d.sysex_data().to_vec())
}

fn in_slices(bytes: &[u8], cuts: &[usize]) -> Run {
    let mut d = Decoder::<6>::new();
    let mut out = Vec::new();
    let mut start = 0;
    for &cut in cuts {
        let cut = cut.clamp(start, bytes.len());
        d.push_slice(&bytes[start..cut], |m| out.push(m));
        start = cut;
    }
    d.push_slice(&bytes[start..], |m| out.push(m));
    (out, d.counters(), d.sysex_data().to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn any_chunking_gives_the_same_messages_and_counters(
        bytes in byte_stream(200),
        mut cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..12),
    ) {
        let reference = byte_by_byte(&bytes);
        let whole = in_slices(&bytes, &[]);
        let mut cut_points: Vec<usize> = cuts.drain(..).map(|i| i.index(bytes.len() + 1)).collect();
        cut_points.sort_unstable();
        let split = in_slices(&bytes, &cut_points);
        prop_assert_eq!(&whole, &reference);
        prop_assert_eq!(&split, &reference);
        // Also one empty slice between every byte.
        let mut d = Decoder::<6>::new();
        let mut out = Vec::new();
        for b in &bytes {
            d.push_slice(&[], |m| out.push(m));
            d.push_slice(core::slice::from_ref(b), |m| out.push(m));
        }
        prop_assert_eq!(&out, &reference.0);
        prop_assert_eq!(d.counters(), reference.1);
    }

    #[test]
    fn counters_add_up(bytes in byte_stream(200)) {
        let (messages, counters, _) = byte_by_byte(&bytes);
        prop_assert_eq!(counters.bytes as usize, bytes.len());
        prop_assert_eq!(counters.messages, counted(&messages));
        // Each byte is accounted for at most once as dropped.
        let data_bytes = bytes.iter().filter(|&&b| b < 0x80).count() as u32;
        prop_assert!(counters.dropped <= data_bytes);
        // Only a status byte or System Reset can abandon a message.
        let status_bytes = bytes
            .iter()
            .filter(|&&b| (0x80..0xF8).contains(&b) || b == 0xFF)
            .count() as u32;
        prop_assert!(counters.abandoned <= status_bytes);
        // Real-time bytes each emit one message, except 0xF9 and 0xFD.
        let realtime = bytes.iter().filter(|&&b| b >= 0xF8 && b != 0xF9 && b != 0xFD).count();
        prop_assert_eq!(messages.iter().filter(|m| m.is_realtime()).count(), realtime);
    }

    /// The interpreter applies only the last message a byte completes: that is right only if
    /// a byte that completes two always completes a System Exclusive message first and then
    /// a SysExStart or Tune Request (none of them acts on the robot).
    #[test]
    fn a_byte_completes_two_messages_only_after_a_system_exclusive(bytes in byte_stream(200)) {
        let mut d = Decoder::<0>::new();
        for &b in &bytes {
            let out: Vec<Message> = d.push(b).collect();
            prop_assert!(out.len() <= 2, "{:#04x}: {:?}", b, out);
            if let [first, second] = out[..] {
                prop_assert!(matches!(first, Message::SysEx { .. }), "{:#04x}: {:?}", b, out);
                prop_assert!(
                    matches!(second, Message::SysExStart | Message::TuneRequest),
                    "{:#04x}: {:?}", b, out
                );
            }
        }
    }

    #[test]
    fn the_decoder_agrees_with_a_model_of_the_spec(bytes in byte_stream(200)) {
        let (messages, counters, sysex) = byte_by_byte(&bytes);
        let mut model = Model::default();
        let mut want = Vec::new();
        for &b in &bytes {
            want.extend(model.push(b));
        }
        prop_assert_eq!(&messages, &want, "bytes {:02X?}", bytes);
        prop_assert_eq!(counters, model.counters);
        let mut want_sysex = model.last_sysex.clone();
        want_sysex.truncate(6);
        prop_assert_eq!(sysex, want_sysex);
        // The end of the input: a message it cut off is truncated, not abandoned.
        let mut d = Decoder::<6>::new();
        d.push_slice(&bytes, |_| {});
        prop_assert_eq!(d.pending(), model.pending());
        prop_assert_eq!(d.finish(), model.finish());
        prop_assert!(!d.pending());
        prop_assert_eq!(d.counters(), model.counters);
    }
}

/// The spec's decoding rules, as plainly as they can be written. Slow, allocating, obvious.
#[derive(Default)]
struct Model {
    /// The status in force (running status, or a system common message being collected).
    status: Option<u8>,
    /// Data bytes collected for the message in progress.
    data: Vec<u8>,
    /// A message has begun and is not complete.
    in_progress: bool,
    /// A System Reset came while a message was in progress: no running status after it.
    forget_status: bool,
    /// The payload of the SysEx being received.
    sysex: Option<Vec<u8>>,
    /// The payload of the latest SysEx (the one being received, or the last one).
    last_sysex: Vec<u8>,
    counters: Counters,
}

impl Model {
    fn push(&mut self, byte: u8) -> Vec<Message> {
        self.counters.bytes += 1;
        let mut out = Vec::new();
        match byte {
            0xFF => {
                // System Reset: emitted at once; a message in progress still completes, but
                // no running status survives it.
                if self.in_progress {
                    self.forget_status = true;
                } else {
                    self.status = None;
                }
                out.push(Message::Reset);
            }
            0xF8..=0xFE => {
                // Real-time: emitted at once, nothing else changes.
                let m = match byte {
                    0xF8 => Some(Message::Clock),
                    0xFA => Some(Message::Start),
                    0xFB => Some(Message::Continue),
                    0xFC => Some(Message::Stop),
                    0xFE => Some(Message::ActiveSensing),
                    _ => None, // 0xF9, 0xFD: ignored
                };
                out.extend(m);
            }
            0x80..=0xF7 => {
                // Any other status byte ends a SysEx (emitted with the data so far).
                if let Some(payload) = self.sysex.take() {
                    out.push(Message::SysEx {
                        len: payload.len() as u32,
                        terminated: byte == 0xF7,
                    });
                    if byte == 0xF7 {
                        self.status = None;
                        self.count(&out);
                        return out;
                    }
                } else if self.in_progress {
                    self.counters.abandoned += 1;
                }
                self.in_progress = false;
                self.forget_status = false;
                self.data.clear();
                self.status = None; // 0xF0..=0xF7 cancel running status
                match byte {
                    0x80..=0xEF | 0xF1 | 0xF2 | 0xF3 => {
                        self.status = Some(byte);
                        self.in_progress = true;
                    }
                    0xF0 => {
                        self.sysex = Some(Vec::new());
                        self.last_sysex.clear();
                        out.push(Message::SysExStart);
                    }
                    0xF6 => out.push(Message::TuneRequest),
                    _ => {} // 0xF4, 0xF5 undefined; lone 0xF7
                }
            }
            _ => {
                if let Some(payload) = &mut self.sysex {
                    payload.push(byte);
                    self.last_sysex.push(byte);
                } else if let Some(status) = self.status {
                    self.data.push(byte);
                    self.in_progress = true;
                    let needed = match status {
                        0xC0..=0xDF | 0xF1 | 0xF3 => 1,
                        _ => 2,
                    };
                    if self.data.len() == needed {
                        out.push(message(status, &self.data));
                        self.data.clear();
                        self.in_progress = false;
                        if status >= 0xF0 || self.forget_status {
                            // No running status for system common, nor after a reset.
                            self.status = None;
                            self.forget_status = false;
                        }
                    }
                } else {
                    self.counters.dropped += 1;
                }
            }
        }
        self.count(&out);
        out
    }

    /// Whether a message (or a SysEx) has begun and is not complete.
    fn pending(&self) -> bool {
        self.in_progress || self.sysex.is_some()
    }

    /// The end of the input: whether a message was cut off; then the power-up state.
    fn finish(&mut self) -> bool {
        let cut = self.pending();
        let counters = self.counters;
        *self = Model {
            counters,
            ..Model::default()
        };
        cut
    }

    fn count(&mut self, out: &[Message]) {
        self.counters.messages += counted(out);
    }
}

fn message(status: u8, d: &[u8]) -> Message {
    let channel = orch_core::Channel::new(status & 0x0F).unwrap();
    let u7 = |b: u8| U7::new(b).unwrap();
    let note = |b: u8| Note::new(b).unwrap();
    let vel = |b: u8| Velocity::new(b).unwrap();
    let u14 = |lsb: u8, msb: u8| U14::new(((msb as u16) << 7) | lsb as u16).unwrap();
    match status {
        0x80..=0x8F => Message::NoteOff {
            channel,
            note: note(d[0]),
            velocity: vel(d[1]),
        },
        0x90..=0x9F => Message::NoteOn {
            channel,
            note: note(d[0]),
            velocity: vel(d[1]),
        },
        0xA0..=0xAF => Message::PolyPressure {
            channel,
            note: note(d[0]),
            pressure: u7(d[1]),
        },
        0xB0..=0xBF => Message::ControlChange {
            channel,
            controller: u7(d[0]),
            value: u7(d[1]),
        },
        0xC0..=0xCF => Message::ProgramChange {
            channel,
            program: u7(d[0]),
        },
        0xD0..=0xDF => Message::ChannelPressure {
            channel,
            pressure: u7(d[0]),
        },
        0xE0..=0xEF => Message::PitchBend {
            channel,
            value: u14(d[0], d[1]),
        },
        0xF1 => Message::QuarterFrame(u7(d[0])),
        0xF2 => Message::SongPosition(u14(d[0], d[1])),
        _ => Message::SongSelect(u7(d[0])),
    }
}
