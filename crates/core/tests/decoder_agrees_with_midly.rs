//! Guards: on well-formed live streams (channel voice messages on all channels, with running
//! status wherever the sender may use it, and real-time bytes other than System Reset anywhere,
//! even between data bytes), orch's decoder gives exactly what an independent implementation
//! gives: midly's `MidiStream`.

mod common;

use common::decode;
use midly::live::{LiveEvent, SystemRealtime};
use midly::stream::MidiStream;
use midly::MidiMessage;
use orch_core::{Channel, Message, Note, Velocity, U14, U7};
use proptest::prelude::*;

fn from_midly(event: LiveEvent) -> Option<Message> {
    Some(match event {
        LiveEvent::Midi { channel, message } => {
            let channel = Channel::new(channel.as_int()).unwrap();
            let note = |k: midly::num::u7| Note::new(k.as_int()).unwrap();
            let vel = |v: midly::num::u7| Velocity::new(v.as_int()).unwrap();
            let u7 = |v: midly::num::u7| U7::new(v.as_int()).unwrap();
            match message {
                MidiMessage::NoteOff { key, vel: v } => Message::NoteOff {
                    channel,
                    note: note(key),
                    velocity: vel(v),
                },
                MidiMessage::NoteOn { key, vel: v } => Message::NoteOn {
                    channel,
                    note: note(key),
                    velocity: vel(v),
                },
                MidiMessage::Aftertouch { key, vel: v } => Message::PolyPressure {
                    channel,
                    note: note(key),
                    pressure: u7(v),
                },
                MidiMessage::Controller { controller, value } => Message::ControlChange {
                    channel,
                    controller: u7(controller),
                    value: u7(value),
                },
                MidiMessage::ProgramChange { program } => Message::ProgramChange {
                    channel,
                    program: u7(program),
                },
                MidiMessage::ChannelAftertouch { vel: v } => Message::ChannelPressure {
                    channel,
                    pressure: u7(v),
                },
                MidiMessage::PitchBend { bend } => Message::PitchBend {
                    channel,
                    value: U14::new(bend.0.as_int()).unwrap(),
                },
            }
        }
        LiveEvent::Realtime(rt) => match rt {
            SystemRealtime::TimingClock => Message::Clock,
            SystemRealtime::Start => Message::Start,
            SystemRealtime::Continue => Message::Continue,
            SystemRealtime::Stop => Message::Stop,
            SystemRealtime::ActiveSensing => Message::ActiveSensing,
            SystemRealtime::Reset => Message::Reset,
            SystemRealtime::Undefined(_) => return None,
        },
        LiveEvent::Common(_) => panic!("no system common message was sent"),
    })
}

/// One channel voice message: status byte and its data bytes.
fn channel_message() -> impl Strategy<Value = (u8, Vec<u8>)> {
    (0x8u8..=0xE, 0u8..3, prop::collection::vec(0u8..0x80, 2)).prop_map(|(kind, c, data)| {
        // Few channels, so running status comes up often.
        let status = (kind << 4) | c;
        let n = if kind == 0xC || kind == 0xD { 1 } else { 2 };
        (status, data[..n].to_vec())
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    #[test]
    fn well_formed_streams_decode_as_midly_decodes_them(
        messages in prop::collection::vec(channel_message(), 0..40),
        // 0xF8..=0xFE: midly treats System Reset (0xFF) like any real-time byte, while orch's
        // decoder goes back to its power-up state (decoder_rules.rs guards that).
        realtime in prop::collection::vec((any::<prop::sample::Index>(), 0xF8u8..=0xFE), 0..10),
        running_status in any::<bool>(),
    ) {
        let mut bytes = Vec::new();
        let mut last = None;
        for (status, data) in &messages {
            if !(running_status && last == Some(*status)) {
                bytes.push(*status);
            }
            last = Some(*status);
            bytes.extend_from_slice(data);
        }
        for (at, rt) in realtime {
            let at = at.index(bytes.len() + 1);
            bytes.insert(at, rt);
        }
        let mut want = Vec::new();
        MidiStream::new().feed(&bytes, |e| want.extend(from_midly(e)));
        let (got, counters) = decode(&bytes);
        prop_assert_eq!(&got, &want, "bytes {:02X?}", bytes);
        prop_assert_eq!(counters.dropped, 0);
        prop_assert_eq!(counters.abandoned, 0);
    }
}
