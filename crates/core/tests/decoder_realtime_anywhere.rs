//! Guards: a real-time byte (0xF8..=0xFE) may arrive anywhere, even between the data bytes of
//! a message or inside SysEx. It is emitted at once, at the position it was inserted, and
//! changes nothing else: the interrupted message, running status, SysEx data and the dropped
//! and abandoned counts stay exactly as without it. 0xF9 and 0xFD emit nothing at all.
//! (The original interpreter broke the message when a clock byte fell inside it.)
//! System Reset (0xFF) does all that too, except that no running status survives it
//! (`decoder_rules.rs` guards that), so the properties over whole streams leave it out.

mod common;

use common::{
    byte_stream, counted, decode_per_byte, decode_with_sysex, realtime_message, REALTIME,
    UNDEFINED_REALTIME,
};
use orch_core::{Counters, Message};
use proptest::prelude::*;

/// Every real-time byte, defined or not, except System Reset.
fn all_realtime() -> Vec<u8> {
    (0xF8..=0xFE).collect()
}

/// Streams of several kinds: every channel voice type, running status, system common, SysEx
/// (terminated, cut short, empty), abandoned and unfinished messages, stray data.
const STREAMS: &[&[u8]] = &[
    &[0x90, 0x3C, 0x7F],                               // Note-On
    &[0x83, 0x3C, 0x40],                               // Note-Off
    &[0xA5, 0x3C, 0x22],                               // poly pressure
    &[0xB7, 0x40, 0x7F],                               // control change
    &[0xC9, 0x05],                                     // program change
    &[0xDA, 0x33],                                     // channel pressure
    &[0xEF, 0x01, 0x40],                               // pitch bend
    &[0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x43, 0x7F],       // running status (thesis Table 4)
    &[0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x80, 0x40, 0x00], // running status, then a new status
    &[0xC0, 0x01, 0x02, 0x03],                         // running status, one data byte
    &[0xF1, 0x35],                                     // quarter frame
    &[0xF2, 0x10, 0x20],                               // song position
    &[0xF3, 0x07],                                     // song select
    &[0xF6],                                           // tune request
    &[0xF0, 0x7E, 0x7F, 0x09, 0x01, 0xF7],             // SysEx (GM on)
    &[0xF0, 0xF7],                                     // empty SysEx
    &[0xF0, 0x01, 0x02, 0x90, 0x3C, 0x7F],             // SysEx cut by a status
    &[0x90, 0x3C, 0x80, 0x3C, 0x00],                   // an abandoned message
    &[0x90, 0x3C, 0x7F, 0x3C],                         // ends inside a running-status message
    &[0x01, 0x02, 0x90, 0x3C, 0x7F],                   // stray data first
    &[0x90, 0x3C, 0x7F, 0xF4, 0x3C, 0x7F],             // F4 cancels running status
    &[0x90, 0x3C, 0x7F, 0xF7, 0x3C, 0x7F],             // lone F7
];

/// What inserting `rt` at `pos` must give: the stream's own messages, with the real-time
/// message (if any) exactly after the messages of the bytes before `pos`.
fn expected(per_byte: &[Vec<Message>], rt: u8, pos: usize) -> Vec<Message> {
    let mut out: Vec<Message> = per_byte[..pos].iter().flatten().copied().collect();
    out.extend(realtime_message(rt));
    out.extend(per_byte[pos..].iter().flatten().copied());
    out
}

fn expected_counters(base: Counters, rt: u8) -> Counters {
    Counters {
        bytes: base.bytes + 1,
        messages: base.messages + u32::from(realtime_message(rt).is_some()),
        ..base
    }
}

#[test]
fn a_realtime_byte_at_any_position_of_any_message_changes_nothing_else() {
    for stream in STREAMS {
        let (per_byte, base_counters) = decode_per_byte(stream);
        let (_, _, base_sysex) = decode_with_sysex::<8>(stream);
        for rt in all_realtime() {
            for pos in 0..=stream.len() {
                let mut bytes = stream.to_vec();
                bytes.insert(pos, rt);
                let (got, counters, sysex) = decode_with_sysex::<8>(&bytes);
                let context = format!("{stream:02X?} with {rt:02X} at {pos}: {bytes:02X?}");
                assert_eq!(got, expected(&per_byte, rt, pos), "{context}");
                assert_eq!(counters, expected_counters(base_counters, rt), "{context}");
                assert_eq!(sysex, base_sysex, "SysEx data changed: {context}");
            }
        }
    }
}

#[test]
fn a_realtime_byte_comes_out_before_the_message_it_interrupted() {
    for (rt, message) in REALTIME {
        let (per_byte, _) = decode_per_byte(&[0x90, 0x3C, rt, 0x7F]);
        assert_eq!(per_byte[2], vec![message], "{rt:02X} is emitted at once");
        assert_eq!(per_byte[3], vec![common::note_on(0, 60, 127)]);
    }
}

#[test]
fn undefined_realtime_bytes_emit_nothing_even_inside_a_message() {
    for rt in UNDEFINED_REALTIME {
        let (per_byte, counters) = decode_per_byte(&[0x90, rt, 0x3C, rt, 0x7F, rt, 0x40, 0x7F]);
        let all: Vec<Message> = per_byte.into_iter().flatten().collect();
        assert_eq!(
            all,
            vec![common::note_on(0, 60, 127), common::note_on(0, 64, 127)]
        );
        assert_eq!(counters.messages, 2);
        assert_eq!((counters.dropped, counters.abandoned), (0, 0));
    }
}

#[test]
fn realtime_bytes_inside_sysex_do_not_end_it_or_enter_its_data() {
    let (got, counters, data) =
        decode_with_sysex::<16>(&[0xF0, 0x01, 0xF8, 0x02, 0xFE, 0xFF, 0x03, 0xF9, 0xF7]);
    assert_eq!(
        got,
        vec![
            Message::SysExStart,
            Message::Clock,
            Message::ActiveSensing,
            Message::Reset,
            Message::SysEx {
                len: 3,
                terminated: true
            },
        ]
    );
    assert_eq!(data, vec![1, 2, 3]);
    assert_eq!(counters.messages, 4);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    /// Any stream, with real-time bytes inserted at any positions: the output is the stream's
    /// own output with each real-time message at the position of its byte.
    #[test]
    fn realtime_bytes_inserted_anywhere_in_any_stream(
        base in byte_stream(64).prop_map(|v| v.into_iter().filter(|&b| b < 0xF8).collect::<Vec<u8>>()),
        inserts in prop::collection::vec((any::<prop::sample::Index>(), 0xF8u8..=0xFE), 1..8),
    ) {
        let (per_byte, base_counters) = decode_per_byte(&base);
        let (_, _, base_sysex) = decode_with_sysex::<4>(&base);
        // Positions in the base stream, in order; several may share one position.
        let mut inserts: Vec<(usize, u8)> = inserts
            .into_iter()
            .map(|(i, rt)| (i.index(base.len() + 1), rt))
            .collect();
        inserts.sort_by_key(|&(p, _)| p);
        let mut bytes = Vec::new();
        let mut want = Vec::new();
        let mut next = 0;
        for pos in 0..=base.len() {
            while next < inserts.len() && inserts[next].0 == pos {
                bytes.push(inserts[next].1);
                want.extend(realtime_message(inserts[next].1));
                next += 1;
            }
            if pos < base.len() {
                bytes.push(base[pos]);
                want.extend(per_byte[pos].iter().copied());
            }
        }
        let (got, counters, sysex) = decode_with_sysex::<4>(&bytes);
        prop_assert_eq!(&got, &want);
        prop_assert_eq!(counters.bytes, base_counters.bytes + inserts.len() as u32);
        prop_assert_eq!(counters.messages, counted(&want));
        prop_assert_eq!(counters.dropped, base_counters.dropped);
        prop_assert_eq!(counters.abandoned, base_counters.abandoned);
        prop_assert_eq!(sysex, base_sysex);
    }
}
