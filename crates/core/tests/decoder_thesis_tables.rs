//! Guards: every byte sequence of the thesis's Tables 3 and 4 (section 3.2.1, "Sequence of
//! MIDI messages without / with running status") decodes to the messages the tables show.

mod common;

use common::{decode, note_off, note_on};
use orch_core::Message;

/// Table 3: three Note-Ons on channel 1 (0 on the wire), each with its own status byte.
#[test]
fn table_3_three_note_ons_each_with_a_status_byte() {
    let table_3 = [0x90, 0x3C, 0x7F, 0x90, 0x40, 0x7F, 0x90, 0x43, 0x7F];
    let (messages, counters) = decode(&table_3);
    assert_eq!(
        messages,
        vec![
            note_on(0, 60, 127),
            note_on(0, 64, 127),
            note_on(0, 67, 127)
        ]
    );
    assert_eq!(counters.bytes, 9);
    assert_eq!(counters.messages, 3);
    assert_eq!(counters.dropped, 0);
    assert_eq!(counters.abandoned, 0);
}

/// Table 4: the same three Note-Ons with running status, then a Note-Off status byte that ends
/// the running Note-On status. The table ends with "..." after `80 40`; the fourth message is
/// completed here with velocity 0.
#[test]
fn table_4_running_status_then_a_note_off() {
    let table_4 = [0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x43, 0x7F, 0x80, 0x40, 0x00];
    let (messages, counters) = decode(&table_4);
    assert_eq!(
        messages,
        vec![
            note_on(0, 60, 127),
            note_on(0, 64, 127),
            note_on(0, 67, 127),
            note_off(0, 64, 0),
        ]
    );
    assert_eq!(counters.bytes, 10);
    assert_eq!(counters.messages, 4);
    assert_eq!(counters.dropped, 0);
    assert_eq!(counters.abandoned, 0);
}

/// Table 4 exactly as printed (`80 40` and then the "..."): the fourth message is not complete,
/// so nothing is emitted for it, and nothing is counted as abandoned either.
#[test]
fn table_4_as_printed_emits_nothing_for_the_unfinished_fourth_message() {
    let as_printed = [0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x43, 0x7F, 0x80, 0x40];
    let (messages, counters) = decode(&as_printed);
    assert_eq!(
        messages,
        vec![
            note_on(0, 60, 127),
            note_on(0, 64, 127),
            note_on(0, 67, 127)
        ]
    );
    assert!(!messages
        .iter()
        .any(|m| matches!(m, Message::NoteOff { .. })));
    assert_eq!(counters.messages, 3);
    assert_eq!(counters.abandoned, 0);
    assert_eq!(counters.dropped, 0);
}

/// After Table 4's Note-Off status, further data pairs are Note-Offs (the thesis: "All the
/// messages after the first Note-Off status byte will be Note-Off messages until a new message
/// with a different status byte is sent").
#[test]
fn table_4_running_note_off_status_continues() {
    let bytes = [
        0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x43, 0x7F, 0x80, 0x40, 0x00, 0x3C, 0x00, 0x43, 0x00,
    ];
    let (messages, _) = decode(&bytes);
    assert_eq!(
        &messages[3..],
        &[note_off(0, 64, 0), note_off(0, 60, 0), note_off(0, 67, 0)]
    );
}

/// The two tables mean the same three notes: running status saves bytes, not meaning.
#[test]
fn tables_3_and_4_decode_to_the_same_three_note_ons() {
    let (t3, _) = decode(&[0x90, 0x3C, 0x7F, 0x90, 0x40, 0x7F, 0x90, 0x43, 0x7F]);
    let (t4, _) = decode(&[0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x43, 0x7F]);
    assert_eq!(t3, t4);
}
