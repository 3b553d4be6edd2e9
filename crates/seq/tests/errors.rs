//! Damaged files are errors with a clear message, never panics.

mod common;

use common::{on, read, smf};
use orch_seq::{SeqError, Song};
use proptest::prelude::*;

fn header(format: u16, tracks: u16, division: u16) -> Vec<u8> {
    let mut b = b"MThd\0\0\0\x06".to_vec();
    b.extend(format.to_be_bytes());
    b.extend(tracks.to_be_bytes());
    b.extend(division.to_be_bytes());
    b
}

fn with_track(mut file: Vec<u8>, declared_len: u32, data: &[u8]) -> Vec<u8> {
    file.extend(b"MTrk");
    file.extend(declared_len.to_be_bytes());
    file.extend(data);
    file
}

#[test]
fn empty_file_is_an_error() {
    assert_eq!(Song::parse(&[]).unwrap_err(), SeqError::Empty);
    assert!(SeqError::Empty.to_string().contains("empty"));
}

#[test]
fn file_without_mthd_is_not_midi() {
    assert_eq!(
        Song::parse(b"RIFF\0\0\0\0RMID").unwrap_err(),
        SeqError::NotMidi
    );
    assert_eq!(Song::parse(b"MTh").unwrap_err(), SeqError::NotMidi);
}

#[test]
fn cut_or_short_header_is_an_error() {
    assert!(matches!(
        Song::parse(b"MThd\0\0"),
        Err(SeqError::BadHeader(_))
    ));
    assert!(matches!(
        Song::parse(b"MThd\0\0\0\x06\0\x01"),
        Err(SeqError::BadHeader(_))
    ));
    assert!(matches!(
        Song::parse(b"MThd\0\0\0\x04\0\x01\0\x01"),
        Err(SeqError::BadHeader(_))
    ));
}

#[test]
fn format_3_is_unsupported() {
    assert_eq!(
        Song::parse(&header(3, 0, 480)).unwrap_err(),
        SeqError::UnsupportedFormat(3)
    );
}

#[test]
fn unplayable_divisions_are_errors() {
    assert!(matches!(
        Song::parse(&header(0, 0, 0)),
        Err(SeqError::BadDivision(_))
    ));
    assert!(matches!(
        Song::parse(&header(0, 0, 0xE700)),
        Err(SeqError::BadDivision(_))
    ));
    assert!(matches!(
        Song::parse(&header(0, 0, 0xE928)),
        Err(SeqError::BadDivision(_))
    )); // −23 fps
}

#[test]
fn missing_tracks_are_an_error() {
    let file = with_track(header(1, 65535, 480), 4, &[0, 0xFF, 0x2F, 0]);
    let err = Song::parse(&file).unwrap_err();
    assert_eq!(
        err,
        SeqError::MissingTracks {
            declared: 65535,
            found: 1
        }
    );
    assert!(err.to_string().contains("65535"));
}

#[test]
fn huge_declared_track_length_is_an_error_without_allocating_it() {
    let file = with_track(header(0, 1, 480), u32::MAX, &[0, 0x90, 60, 100]);
    assert!(matches!(
        Song::parse(&file),
        Err(SeqError::ChunkPastEnd {
            declared: u32::MAX,
            ..
        })
    ));
}

#[test]
fn huge_declared_sysex_length_is_an_error() {
    let data = [0, 0xF0, 0x8F, 0xFF, 0xFF, 0x7F, 1, 2, 3];
    let file = with_track(header(0, 1, 480), data.len() as u32, &data);
    let err = Song::parse(&file).unwrap_err();
    assert!(matches!(err, SeqError::Event { track: 0, .. }), "{err}");
}

#[test]
fn data_byte_with_no_running_status_is_an_error() {
    let data = [0, 60, 100, 0, 0xFF, 0x2F, 0];
    let file = with_track(header(0, 1, 480), data.len() as u32, &data);
    let err = Song::parse(&file).unwrap_err();
    assert_eq!(
        err,
        SeqError::Event {
            track: 0,
            offset: 23,
            reason: "data byte where a status byte must be, with no running status"
        }
    );
    assert!(err.to_string().starts_with("track 1: data byte"), "{err}");
}

#[test]
fn event_cut_by_the_end_of_its_track_is_an_error() {
    for data in [
        &[0x00, 0x90, 60][..],
        &[0x81][..],
        &[0x00][..],
        &[0x00, 0xFF][..],
        &[0, 0xFF, 0x51, 3, 7],
    ] {
        let file = with_track(header(0, 1, 480), data.len() as u32, data);
        assert!(
            matches!(Song::parse(&file), Err(SeqError::Event { .. })),
            "{data:?}"
        );
    }
}

#[test]
fn system_common_status_in_a_track_is_an_error() {
    let data = [0, 0xF3, 1];
    let file = with_track(header(0, 1, 480), 3, &data);
    assert!(matches!(Song::parse(&file), Err(SeqError::Event { .. })));
}

#[test]
fn unknown_chunks_are_skipped_and_missing_end_of_track_is_accepted() {
    let mut file = header(0, 1, 480);
    file.extend(b"XFIH\0\0\0\x03abc");
    let file = with_track(file, 4, &[0, 0x90, 60, 100]);
    let song = Song::parse(&file).unwrap();
    assert_eq!(song.notes(), 1);
}

#[test]
fn a_meta_event_midly_cannot_decode_is_ignored() {
    // Key signature with one data byte instead of two: nothing played depends on it.
    let bytes = smf(
        0,
        480,
        &[vec![(0, vec![0xFF, 0x59, 0x01, 0x00]), (0, on(0, 60))]],
    );
    assert_eq!(Song::parse(&bytes).unwrap().notes(), 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = Song::parse(&bytes);
    }

    #[test]
    fn random_tracks_after_a_valid_header_never_panic(
        format in 0u16..3,
        division in prop_oneof![Just(480u16), Just(0xE728u16), any::<u16>()],
        data in proptest::collection::vec(any::<u8>(), 0..200),
        declared in prop_oneof![Just(None), any::<u32>().prop_map(Some)],
    ) {
        let len = declared.unwrap_or(data.len() as u32);
        let file = with_track(header(format, 1, division), len, &data);
        match Song::parse(&file) {
            Err(e) => prop_assert!(!e.to_string().is_empty()),
            Ok(song) => {
                for t in [0, 1, song.duration_us(), u64::MAX / 2, u64::MAX] {
                    let _ = song.bar_beat(t);
                    let _ = song.tick_at_time(t);
                    let _ = song.tempo_at(t);
                }
                let _ = song.time_at_tick(u64::MAX / 4);
            }
        }
    }

    #[test]
    fn scribbling_on_a_real_file_never_panics(
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
    ) {
        let mut bytes = read("m21-test09.mid");
        for (at, value) in edits {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        let _ = Song::parse(&bytes);
    }
}

#[test]
fn a_zero_tempo_is_an_error_naming_the_track_and_tick() {
    // Format 1: a tempo track that is fine, and a second track that sets 0 µs per quarter
    // note at tick 960 (after a note at tick 0 and 480).
    let file = smf(
        1,
        480,
        &[
            vec![(0, common::tempo(500_000))],
            vec![
                (0, on(0, 60)),
                (480, on(0, 62)),
                (480, common::tempo(0)),
                (0, on(0, 64)),
            ],
        ],
    );
    let e = Song::parse(&file).unwrap_err();
    let SeqError::ZeroTempo {
        track,
        tick,
        offset,
    } = e
    else {
        panic!("not ZeroTempo: {e:?}");
    };
    assert_eq!((track, tick), (1, 960));
    // The event's delta time (480 = 83 60) is at `offset`, then FF 51 03 00 00 00.
    assert_eq!(
        &file[offset..offset + 8],
        &[0x83, 0x60, 0xFF, 0x51, 0x03, 0, 0, 0]
    );
    let message = e.to_string();
    assert!(message.contains("track 2"), "{message}");
    assert!(message.contains("tick 960"), "{message}");
    assert!(message.contains("0 µs per quarter"), "{message}");
    // The smallest tempo there is, 1 µs per quarter, is still played.
    let file = smf(1, 480, &[vec![(0, common::tempo(1)), (0, on(0, 60))]]);
    assert!(Song::parse(&file).is_ok());
}
