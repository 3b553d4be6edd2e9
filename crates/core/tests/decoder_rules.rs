//! Guards the MIDI 1.0 decoding rules of the spec, one test each: running status and what
//! cancels it, undefined status bytes, dropped and abandoned counts, SysEx framing and its
//! bounded buffer, unfinished messages, 14-bit values, and every channel voice message on all
//! 16 channels.

mod common;

use common::{ch, decode, decode_with_sysex, note_on};
use orch_core::{Decoder, Message, Note, Velocity, U14, U7};

fn sysex(len: u32, terminated: bool) -> Message {
    Message::SysEx { len, terminated }
}

#[test]
fn every_channel_voice_message_on_all_16_channels() {
    for c in 0..16u8 {
        let channel = ch(c);
        let cases: [(Vec<u8>, Message); 7] = [
            (
                vec![0x80 | c, 0x3C, 0x11],
                Message::NoteOff {
                    channel,
                    note: Note::new(0x3C).unwrap(),
                    velocity: Velocity::new(0x11).unwrap(),
                },
            ),
            (
                vec![0x90 | c, 0x3D, 0x12],
                Message::NoteOn {
                    channel,
                    note: Note::new(0x3D).unwrap(),
                    velocity: Velocity::new(0x12).unwrap(),
                },
            ),
            (
                vec![0xA0 | c, 0x3E, 0x13],
                Message::PolyPressure {
                    channel,
                    note: Note::new(0x3E).unwrap(),
                    pressure: U7::new(0x13).unwrap(),
                },
            ),
            (
                vec![0xB0 | c, 0x07, 0x14],
                Message::ControlChange {
                    channel,
                    controller: U7::new(0x07).unwrap(),
                    value: U7::new(0x14).unwrap(),
                },
            ),
            (
                vec![0xC0 | c, 0x15],
                Message::ProgramChange {
                    channel,
                    program: U7::new(0x15).unwrap(),
                },
            ),
            (
                vec![0xD0 | c, 0x16],
                Message::ChannelPressure {
                    channel,
                    pressure: U7::new(0x16).unwrap(),
                },
            ),
            (
                vec![0xE0 | c, 0x17, 0x18],
                Message::PitchBend {
                    channel,
                    value: U14::new((0x18 << 7) | 0x17).unwrap(),
                },
            ),
        ];
        for (bytes, want) in cases {
            let (got, counters) = decode(&bytes);
            assert_eq!(got, vec![want], "{bytes:02X?}");
            assert_eq!(want.channel(), Some(channel));
            assert_eq!(counters.messages, 1);
        }
    }
}

#[test]
fn running_status_applies_to_every_channel_voice_type() {
    for status in (0x80..=0xE0).step_by(0x10) {
        let n = if status == 0xC0 || status == 0xD0 {
            1
        } else {
            2
        };
        let status = status | 0x05;
        let mut bytes = vec![status];
        for i in 0..3 * n {
            bytes.push(0x10 + i as u8);
        }
        let (got, counters) = decode(&bytes);
        assert_eq!(got.len(), 3, "{bytes:02X?}: {got:?}");
        assert!(got.iter().all(|m| m.channel() == Some(ch(5))));
        assert_eq!((counters.dropped, counters.abandoned), (0, 0));
    }
}

#[test]
fn velocity_zero_note_on_is_decoded_as_it_came() {
    // The decoder keeps the wire's meaning; the interpreter treats it as a Note-Off.
    assert_eq!(decode(&[0x92, 0x40, 0x00]).0, vec![note_on(2, 0x40, 0)]);
}

#[test]
fn sysex_and_system_common_cancel_running_status() {
    // Each of F0..=F7 between a Note-On and two more data bytes: the data bytes then have
    // no status and are dropped.
    let cases: [(&[u8], Vec<Message>); 8] = [
        (
            &[0xF0, 0x01, 0xF7],
            vec![Message::SysExStart, sysex(1, true)],
        ),
        (
            &[0xF1, 0x05],
            vec![Message::QuarterFrame(U7::new(5).unwrap())],
        ),
        (
            &[0xF2, 0x01, 0x02],
            vec![Message::SongPosition(U14::new(0x101).unwrap())],
        ),
        (
            &[0xF3, 0x05],
            vec![Message::SongSelect(U7::new(5).unwrap())],
        ),
        (&[0xF4], vec![]),
        (&[0xF5], vec![]),
        (&[0xF6], vec![Message::TuneRequest]),
        (&[0xF7], vec![]),
    ];
    for (between, middle) in cases {
        let mut bytes = vec![0x90, 0x3C, 0x7F];
        bytes.extend_from_slice(between);
        bytes.extend_from_slice(&[0x3D, 0x7F]);
        let (got, counters) = decode(&bytes);
        let mut want = vec![note_on(0, 0x3C, 0x7F)];
        want.extend(middle);
        assert_eq!(got, want, "{bytes:02X?}");
        assert_eq!(counters.dropped, 2, "{bytes:02X?}");
        assert_eq!(counters.abandoned, 0, "{bytes:02X?}");
    }
}

#[test]
fn realtime_bytes_do_not_cancel_running_status() {
    for rt in 0xF8..=0xFEu8 {
        let (got, counters) = decode(&[0x90, 0x3C, 0x7F, rt, 0x3D, 0x7F]);
        assert_eq!(got.first(), Some(&note_on(0, 0x3C, 0x7F)));
        assert_eq!(got.last(), Some(&note_on(0, 0x3D, 0x7F)), "{rt:02X}");
        assert_eq!(counters.dropped, 0, "{rt:02X}");
    }
}

#[test]
fn running_status_survives_a_system_common_message_only_if_resent() {
    let (got, counters) = decode(&[0x90, 0x3C, 0x7F, 0xF6, 0x90, 0x3D, 0x7F, 0x3E, 0x7F]);
    assert_eq!(
        got,
        vec![
            note_on(0, 0x3C, 0x7F),
            Message::TuneRequest,
            note_on(0, 0x3D, 0x7F),
            note_on(0, 0x3E, 0x7F)
        ]
    );
    assert_eq!(counters.dropped, 0);
}

#[test]
fn undefined_f4_and_f5_are_ignored_and_cancel_running_status() {
    for undefined in [0xF4, 0xF5] {
        let (got, counters) = decode(&[undefined, 0x90, 0x3C, 0x7F, undefined, 0x3D, 0x7F]);
        assert_eq!(got, vec![note_on(0, 0x3C, 0x7F)], "{undefined:02X}");
        assert_eq!(counters.messages, 1);
        assert_eq!(counters.dropped, 2);
        assert_eq!(counters.abandoned, 0);
        assert_eq!(counters.bytes, 7);
    }
}

#[test]
fn undefined_f9_and_fd_are_ignored_with_no_other_effect() {
    for undefined in [0xF9, 0xFD] {
        let with = decode(&[
            undefined, 0x90, undefined, 0x3C, 0x7F, undefined, 0x3D, 0x7F,
        ]);
        let without = decode(&[0x90, 0x3C, 0x7F, 0x3D, 0x7F]);
        assert_eq!(with.0, without.0, "{undefined:02X}");
        assert_eq!(with.1.messages, 2);
        assert_eq!((with.1.dropped, with.1.abandoned), (0, 0));
        assert_eq!(with.1.bytes, 8);
    }
}

#[test]
fn data_bytes_with_no_status_are_dropped_one_count_each() {
    // At power-up.
    let (got, counters) = decode(&[0x3C, 0x7F, 0x00]);
    assert!(got.is_empty());
    assert_eq!(counters.dropped, 3);
    // After a system common message completes (it has no running status).
    let (got, counters) = decode(&[0xF3, 0x01, 0x02, 0x03]);
    assert_eq!(got, vec![Message::SongSelect(U7::new(1).unwrap())]);
    assert_eq!(counters.dropped, 2);
    // After a tune request, after a SysEx, after a lone EOX.
    for bytes in [
        &[0xF6, 0x01][..],
        &[0xF0, 0xF7, 0x01][..],
        &[0xF7, 0x01][..],
    ] {
        assert_eq!(decode(bytes).1.dropped, 1, "{bytes:02X?}");
    }
    // Data bytes inside a SysEx are its payload, not dropped.
    assert_eq!(decode(&[0xF0, 0x01, 0x02, 0xF7]).1.dropped, 0);
}

#[test]
fn a_status_byte_before_the_message_is_complete_abandons_it_once() {
    let cases: [(&[u8], Vec<Message>); 7] = [
        // After one data byte.
        (
            &[0x90, 0x3C, 0x80, 0x3C, 0x00],
            vec![common::note_off(0, 0x3C, 0)],
        ),
        // Before any data byte.
        (
            &[0x90, 0x80, 0x3C, 0x00],
            vec![common::note_off(0, 0x3C, 0)],
        ),
        // Under running status, after the first data byte of the next message.
        (
            &[0x90, 0x3C, 0x7F, 0x3D, 0x80, 0x3C, 0x00],
            vec![note_on(0, 0x3C, 0x7F), common::note_off(0, 0x3C, 0)],
        ),
        // Abandoned by SysEx, by a tune request, by an undefined status, by a lone EOX.
        (
            &[0x90, 0x3C, 0xF0, 0xF7],
            vec![Message::SysExStart, sysex(0, true)],
        ),
        (&[0xB0, 0x07, 0xF6], vec![Message::TuneRequest]),
        (&[0xE0, 0x00, 0xF5], vec![]),
        (&[0xF2, 0x00, 0xF7], vec![]),
    ];
    for (bytes, want) in cases {
        let (got, counters) = decode(bytes);
        assert_eq!(got, want, "{bytes:02X?}");
        assert_eq!(counters.abandoned, 1, "{bytes:02X?}");
        assert_eq!(counters.dropped, 0, "{bytes:02X?}");
    }
    // Real-time bytes in the middle do not make it count twice, nor at all.
    let (got, counters) = decode(&[0x90, 0xF8, 0x3C, 0xFE, 0x80, 0x3C, 0x00]);
    assert_eq!(counters.abandoned, 1);
    assert_eq!(got.last(), Some(&common::note_off(0, 0x3C, 0)));
    assert_eq!(decode(&[0x90, 0x3C, 0xF8, 0x7F]).1.abandoned, 0);
    // A complete message is not abandoned by the next status byte.
    assert_eq!(decode(&[0x90, 0x3C, 0x7F, 0x80, 0x3C, 0x00]).1.abandoned, 0);
    // Two unfinished messages in a row count twice, once each.
    assert_eq!(decode(&[0x90, 0x3C, 0x80, 0x3C, 0xC0]).1.abandoned, 2);
}

#[test]
fn sysex_cut_short_by_a_status_byte_is_emitted_with_its_data_so_far() {
    let (got, counters, data) = decode_with_sysex::<8>(&[0xF0, 0x41, 0x10, 0x42, 0x90, 0x3C, 0x7F]);
    assert_eq!(
        got,
        vec![Message::SysExStart, sysex(3, false), note_on(0, 0x3C, 0x7F)]
    );
    assert_eq!(data, vec![0x41, 0x10, 0x42]);
    assert_eq!(counters.messages, 2, "SysExStart is not counted");
    assert_eq!(
        counters.abandoned, 0,
        "a SysEx cut short is emitted, not abandoned"
    );

    // Every non-real-time status byte ends it; the status byte then does its own job.
    for status in (0x80..=0xF6u8).filter(|s| *s != 0xF0) {
        let (got, _, data) = decode_with_sysex::<8>(&[0xF0, 0x01, 0x02, status]);
        assert_eq!(
            &got[..2],
            &[Message::SysExStart, sysex(2, false)],
            "{status:02X}"
        );
        assert_eq!(data, vec![1, 2], "{status:02X}");
    }
    // A new SysEx ends the old one: one byte, two messages.
    let (got, _, data) = decode_with_sysex::<8>(&[0xF0, 0x01, 0xF0, 0x02, 0x03, 0xF7]);
    assert_eq!(
        got,
        vec![
            Message::SysExStart,
            sysex(1, false),
            Message::SysExStart,
            sysex(2, true)
        ]
    );
    assert_eq!(data, vec![2, 3], "sysex_data() is the latest SysEx's");
    // A tune request ends it and is emitted after it.
    let (got, _, _) = decode_with_sysex::<0>(&[0xF0, 0x01, 0xF6]);
    assert_eq!(
        got,
        vec![Message::SysExStart, sysex(1, false), Message::TuneRequest]
    );
}

#[test]
fn sysex_is_reported_as_start_and_end() {
    let (got, counters, data) = decode_with_sysex::<8>(&[0xF0, 0x7E, 0x7F, 0x09, 0x01, 0xF7]);
    assert_eq!(got, vec![Message::SysExStart, sysex(4, true)]);
    assert_eq!(data, vec![0x7E, 0x7F, 0x09, 0x01]);
    assert_eq!(counters.messages, 1);
    assert_eq!(counters.bytes, 6);
    let (got, _, data) = decode_with_sysex::<8>(&[0xF0, 0xF7]);
    assert_eq!(got, vec![Message::SysExStart, sysex(0, true)]);
    assert!(data.is_empty());
}

#[test]
fn a_lone_eox_is_ignored() {
    let (got, counters) = decode(&[0xF7]);
    assert!(got.is_empty());
    assert_eq!(counters.bytes, 1);
    assert_eq!(
        (counters.messages, counters.dropped, counters.abandoned),
        (0, 0, 0)
    );
    // A second EOX after a terminated SysEx is lone too.
    let (got, counters) = decode(&[0xF0, 0x01, 0xF7, 0xF7]);
    assert_eq!(got, vec![Message::SysExStart, sysex(1, true)]);
    assert_eq!(counters.messages, 1);
}

#[test]
fn a_stream_ending_inside_a_message_emits_nothing_for_it() {
    let unfinished: [&[u8]; 7] = [
        &[0x90],
        &[0x90, 0x3C],
        &[0x90, 0x3C, 0x7F, 0x3D],
        &[0xE0, 0x00],
        &[0xF2, 0x00],
        &[0xF1],
        &[0xC0],
    ];
    for bytes in unfinished {
        let (got, counters) = decode(bytes);
        let complete = usize::from(bytes.len() == 4);
        assert_eq!(got.len(), complete, "{bytes:02X?}: {got:?}");
        assert_eq!(counters.messages as usize, complete);
        assert_eq!(counters.abandoned, 0);
        assert_eq!(counters.dropped, 0);
    }
    // Inside a SysEx: only its start was reported.
    let (got, counters) = decode(&[0xF0, 0x01, 0x02]);
    assert_eq!(got, vec![Message::SysExStart]);
    assert_eq!(counters.messages, 0);
}

/// The end of the input is not a status byte: `finish` says a message was cut off, and it is
/// never counted as abandoned; a stream that ends between messages cut nothing.
#[test]
fn a_message_cut_off_by_the_end_of_input_is_reported_by_finish_not_abandoned() {
    for (bytes, cut) in [
        (&[0x90][..], true),
        (&[0x90, 0x3C], true),
        (&[0x90, 0x3C, 0x7F, 0x3D], true),
        (&[0xF2, 0x00], true),
        (&[0xF0, 0x01, 0x02], true),
        (&[0xF0], true),
        (&[0x90, 0x3C, 0x7F], false),
        // Running status in force but no data byte yet: nothing was cut.
        (&[0x90, 0x3C, 0x7F, 0xF8], false),
        (&[0xF0, 0x01, 0xF7], false),
        (&[0x3C], false),
        (&[], false),
    ] {
        let mut d = Decoder::<0>::new();
        d.push_slice(bytes, |_| {});
        assert_eq!(d.pending(), cut, "{bytes:02X?}");
        assert_eq!(d.finish(), cut, "{bytes:02X?}");
        assert_eq!(d.counters().abandoned, 0, "{bytes:02X?}");
        assert_eq!(d.counters().bytes, bytes.len() as u32, "counters are kept");
        assert!(!d.pending());
        // After `finish` the decoder starts a new stream: no running status is left.
        let mut got = Vec::new();
        d.push_slice(&[0x3C, 0x7F], |m| got.push(m));
        assert!(got.is_empty(), "{bytes:02X?}: {got:?}");
        assert!(!d.finish(), "{bytes:02X?}");
    }
}

/// System Reset puts the receiver back in its power-up state (MIDI 1.0): running status is
/// gone, so data bytes after it are dropped, not played with the old status. The original
/// decoder (and midly) let `90 40 64 FF 3C 64` play a second note.
#[test]
fn system_reset_clears_running_status() {
    let (got, counters) = decode(&[0x90, 0x40, 0x64, 0xFF, 0x3C, 0x64]);
    assert_eq!(got, vec![note_on(0, 0x40, 0x64), Message::Reset]);
    assert_eq!((counters.dropped, counters.abandoned), (2, 0));
    // A new status byte after it works as ever.
    let (got, _) = decode(&[0x90, 0x40, 0x64, 0xFF, 0x90, 0x3C, 0x64]);
    assert_eq!(
        got,
        vec![
            note_on(0, 0x40, 0x64),
            Message::Reset,
            note_on(0, 0x3C, 0x64)
        ]
    );
}

/// A System Reset inside a message is emitted at once and the message still completes, like
/// any real-time byte; but its status is not kept as running status afterwards. Inside a
/// SysEx it changes nothing (a SysEx cancels running status anyway).
#[test]
fn system_reset_inside_a_message_lets_it_finish_then_cancels_running_status() {
    let (got, counters) = decode(&[0x90, 0x40, 0xFF, 0x64, 0x3C, 0x64]);
    assert_eq!(got, vec![Message::Reset, note_on(0, 0x40, 0x64)]);
    assert_eq!((counters.abandoned, counters.dropped), (0, 2));
    // Between the data bytes of a running-status message too.
    let (got, counters) = decode(&[0x90, 0x40, 0x64, 0x3C, 0xFF, 0x64, 0x3E, 0x64]);
    assert_eq!(
        got,
        vec![
            note_on(0, 0x40, 0x64),
            Message::Reset,
            note_on(0, 0x3C, 0x64)
        ]
    );
    assert_eq!(counters.dropped, 2);
    // A new status byte after the reset is kept as running status again.
    let (got, _) = decode(&[0x90, 0x40, 0xFF, 0x64, 0x90, 0x3C, 0x64, 0x3E, 0x64]);
    assert_eq!(got.len(), 4, "{got:?}");
    let (got, counters) = decode(&[0xF0, 0x01, 0xFF, 0x02, 0xF7]);
    assert_eq!(
        got,
        vec![Message::SysExStart, Message::Reset, sysex(2, true)]
    );
    assert_eq!((counters.abandoned, counters.dropped), (0, 0));
}

#[test]
fn the_sysex_buffer_keeps_the_first_n_bytes_and_len_counts_all() {
    let mut bytes = vec![0xF0];
    bytes.extend(1..=20u8);
    bytes.push(0xF7);
    let (got, _, data) = decode_with_sysex::<4>(&bytes);
    assert_eq!(got[1], sysex(20, true));
    assert_eq!(data, vec![1, 2, 3, 4]);
    let (_, _, data) = decode_with_sysex::<32>(&bytes);
    assert_eq!(data, (1..=20).collect::<Vec<u8>>());
    let (got, _, data) = decode_with_sysex::<0>(&bytes);
    assert_eq!(got[1], sysex(20, true));
    assert!(data.is_empty());
    // Exactly N.
    let (_, _, data) = decode_with_sysex::<4>(&[0xF0, 9, 8, 7, 6, 0xF7]);
    assert_eq!(data, vec![9, 8, 7, 6]);
    // A longer SysEx does not leak into the buffer of a shorter one after it.
    let (_, _, data) = decode_with_sysex::<4>(&[0xF0, 1, 2, 3, 4, 5, 0xF7, 0xF0, 9, 0xF7]);
    assert_eq!(data, vec![9]);
}

#[test]
fn pitch_bend_and_song_position_are_14_bit_lsb_first() {
    let bend = |lsb, msb| decode(&[0xE3, lsb, msb]).0[0];
    assert_eq!(
        bend(0x00, 0x40),
        Message::PitchBend {
            channel: ch(3),
            value: U14::CENTER
        }
    );
    assert_eq!(
        bend(0x01, 0x00),
        Message::PitchBend {
            channel: ch(3),
            value: U14::new(1).unwrap()
        }
    );
    assert_eq!(
        bend(0x00, 0x01),
        Message::PitchBend {
            channel: ch(3),
            value: U14::new(128).unwrap()
        }
    );
    assert_eq!(
        bend(0x7F, 0x7F),
        Message::PitchBend {
            channel: ch(3),
            value: U14::MAX
        }
    );
    let song = |lsb, msb| decode(&[0xF2, lsb, msb]).0[0];
    assert_eq!(
        song(0x05, 0x00),
        Message::SongPosition(U14::new(5).unwrap())
    );
    assert_eq!(
        song(0x00, 0x05),
        Message::SongPosition(U14::new(5 << 7).unwrap())
    );
    assert_eq!(song(0x7F, 0x7F), Message::SongPosition(U14::MAX));
    assert_eq!(U14::new((5 << 7) | 3).unwrap().get(), 643);
}

#[test]
fn quarter_frame_song_select_and_tune_request() {
    let (got, _) = decode(&[0xF1, 0x35]);
    assert_eq!(got, vec![Message::QuarterFrame(U7::new(0x35).unwrap())]);
    assert_eq!(Message::quarter_frame_parts(U7::new(0x35).unwrap()), (3, 5));
    assert_eq!(
        Message::quarter_frame_parts(U7::new(0x7F).unwrap()),
        (7, 15)
    );
    // Every quarter-frame piece type 0..=7.
    for piece in 0..8u8 {
        let data = (piece << 4) | 0x0A;
        assert_eq!(
            decode(&[0xF1, data]).0,
            vec![Message::QuarterFrame(U7::new(data).unwrap())]
        );
    }
    assert_eq!(
        decode(&[0xF3, 0x11]).0,
        vec![Message::SongSelect(U7::new(0x11).unwrap())]
    );
    assert_eq!(decode(&[0xF6]).0, vec![Message::TuneRequest]);
}

#[test]
fn realtime_messages_are_decoded() {
    for (byte, message) in common::REALTIME {
        let (got, counters) = decode(&[byte]);
        assert_eq!(got, vec![message]);
        assert!(message.is_realtime());
        assert_eq!(counters.messages, 1);
    }
}

#[test]
fn counters_count_bytes_messages_dropped_and_abandoned() {
    let bytes = [
        0x01, // dropped
        0x90, 0x3C, 0x7F, // message
        0xF8, // message (real-time)
        0x3D, 0x80, // abandoned
        0x3C, 0x00, // message
        0xF0, 0x01, 0xF7, // message (SysExStart not counted)
        0x02, 0x03, // dropped twice
    ];
    let (_, c) = decode(&bytes);
    assert_eq!(c.bytes, bytes.len() as u32);
    assert_eq!(c.messages, 4);
    assert_eq!(c.dropped, 3);
    assert_eq!(c.abandoned, 1);
}

#[test]
fn reset_forgets_the_message_in_progress_and_running_status_but_keeps_counters() {
    let mut d = Decoder::<4>::new();
    d.push_slice(&[0x90, 0x3C, 0x7F, 0x3D], |_| {});
    d.reset();
    let mut got = Vec::new();
    d.push_slice(&[0x7F, 0x3E, 0x7F], |m| got.push(m));
    assert!(got.is_empty());
    assert_eq!(d.counters().bytes, 7);
    assert_eq!(d.counters().messages, 1);
    assert_eq!(d.counters().dropped, 3);
    let mut d = Decoder::<4>::new();
    d.push_slice(&[0xF0, 0x01], |_| {});
    assert!(d.in_sysex());
    d.reset();
    assert!(!d.in_sysex());
}
