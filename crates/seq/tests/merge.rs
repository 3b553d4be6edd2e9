//! The order of simultaneous events, and which messages are kept.

mod common;

use common::{off, on, smf};
use orch_seq::Song;

fn bytes_of(song: &Song) -> Vec<Vec<u8>> {
    song.events().iter().map(|e| e.bytes.to_vec()).collect()
}

#[test]
fn note_off_comes_before_note_on_at_the_same_tick_when_the_on_is_in_an_earlier_track() {
    let bytes = smf(
        1,
        480,
        &[
            vec![(0, on(0, 60)), (480, on(0, 60))],
            vec![(480, off(0, 60))],
        ],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(bytes_of(&song), [on(0, 60), off(0, 60), on(0, 60)]);
}

#[test]
fn note_off_comes_before_note_on_at_the_same_tick_when_the_off_is_in_an_earlier_track() {
    let bytes = smf(
        1,
        480,
        &[
            vec![(480, vec![0x90, 60, 0])],
            vec![(0, on(0, 60)), (480, on(0, 60))],
        ],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(bytes_of(&song), [on(0, 60), vec![0x90, 60, 0], on(0, 60)]);
}

#[test]
fn note_off_comes_before_note_on_at_the_same_tick_within_one_track() {
    let bytes = smf(
        0,
        480,
        &[vec![(0, on(0, 60)), (480, on(0, 60)), (0, off(0, 60))]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(bytes_of(&song), [on(0, 60), off(0, 60), on(0, 60)]);
}

#[test]
fn zero_length_note_keeps_its_off_after_its_on() {
    let bytes = smf(
        0,
        480,
        &[vec![(0, on(0, 60)), (0, off(0, 60)), (0, on(0, 62))]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(bytes_of(&song), [on(0, 60), off(0, 60), on(0, 62)]);
}

#[test]
fn hoisted_note_off_moves_ahead_of_all_note_ons_but_not_other_events() {
    // At tick 480: track 0 has a controller then note 64 on; track 1 releases note 60.
    let bytes = smf(
        1,
        480,
        &[
            vec![(0, on(0, 60)), (480, vec![0xB0, 7, 100]), (0, on(0, 64))],
            vec![(480, off(0, 60))],
        ],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(
        bytes_of(&song),
        [on(0, 60), vec![0xB0, 7, 100], off(0, 60), on(0, 64)]
    );
}

#[test]
fn simultaneous_events_keep_track_order_then_position_in_track() {
    let bytes = smf(
        1,
        480,
        &[
            vec![(10, vec![0xB0, 7, 1]), (0, vec![0xB0, 7, 2])],
            vec![(10, vec![0xC0, 5]), (0, on(1, 60))],
            vec![(10, vec![0xB2, 10, 64])],
        ],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(
        bytes_of(&song),
        [
            vec![0xB0, 7, 1],
            vec![0xB0, 7, 2],
            vec![0xC0, 5],
            on(1, 60),
            vec![0xB2, 10, 64]
        ]
    );
    let tracks: Vec<u16> = song.events().iter().map(|e| e.track).collect();
    assert_eq!(tracks, [0, 0, 1, 1, 2]);
}

#[test]
fn every_channel_message_and_sysex_is_kept_and_meta_events_are_not() {
    let bytes = smf(
        0,
        480,
        &[vec![
            (0, vec![0xFF, 0x03, 0x01, b'x']),
            (0, on(3, 60)),
            (0, vec![0xA3, 60, 10]),
            (0, vec![0xB3, 64, 127]),
            (0, vec![0xB3, 123, 0]),
            (0, vec![0xC3, 1]),
            (0, vec![0xD3, 20]),
            (0, vec![0xE3, 0x00, 0x40]),
            (0, vec![0xF0, 0x04, 0x7E, 0x7F, 0x09, 0xF7]),
            (0, vec![0x83, 60, 64]),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(
        bytes_of(&song),
        [
            on(3, 60),
            vec![0xA3, 60, 10],
            vec![0xB3, 64, 127],
            vec![0xB3, 123, 0],
            vec![0xC3, 1],
            vec![0xD3, 20],
            vec![0xE3, 0x00, 0x40],
            vec![0xF0, 0x7E, 0x7F, 0x09, 0xF7],
            vec![0x83, 60, 64],
        ]
    );
    assert_eq!(song.notes(), 1);
}

#[test]
fn running_status_in_the_file_is_expanded_and_survives_meta_events() {
    let bytes = smf(
        0,
        480,
        &[vec![
            (0, vec![0x91, 60, 100]),
            (0, vec![62, 100]),
            (0, vec![0xFF, 0x01, 0x01, b'x']),
            (10, vec![60, 0]),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(
        bytes_of(&song),
        [vec![0x91, 60, 100], vec![0x91, 62, 100], vec![0x91, 60, 0]]
    );
    assert_eq!(song.notes(), 2);
}

#[test]
fn split_sysex_packets_are_joined_at_the_first_packets_time() {
    let bytes = smf(
        0,
        480,
        &[vec![
            (5, vec![0xF0, 0x02, 0x43, 0x12]),
            (10, vec![0xF7, 0x02, 0x00, 0xF7]),
            (0, vec![0xF7, 0x01, 0xF8]), // a bare escape: dropped
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(bytes_of(&song), [vec![0xF0, 0x43, 0x12, 0x00, 0xF7]]);
    assert_eq!(song.events()[0].tick, 5);
}
