//! The byte stream a sequencer sends decodes back to the song.

mod common;

use common::{read, smf, vlq};
use orch_core::{Decoder, Message};
use orch_seq::{wire, RunningStatus, Song};
use proptest::prelude::*;

/// Decodes `bytes` with the core's decoder (SysEx notifications left out).
fn decode<'a>(bytes: impl IntoIterator<Item = &'a u8>) -> Vec<(Message, Vec<u8>)> {
    let mut d = Decoder::<64>::new();
    let mut out = Vec::new();
    for &b in bytes {
        for m in d.push(b) {
            if m != Message::SysExStart {
                let data = if matches!(m, Message::SysEx { .. }) {
                    d.sysex_data().to_vec()
                } else {
                    Vec::new()
                };
                out.push((m, data));
            }
        }
    }
    out
}

/// Each event decoded on its own, from a fresh decoder.
fn song_messages(song: &Song) -> Vec<(Message, Vec<u8>)> {
    song.events()
        .iter()
        .flat_map(|e| decode(e.bytes.iter()))
        .collect()
}

fn stream_bytes(song: &Song, mode: RunningStatus) -> Vec<u8> {
    wire(song.messages(), mode)
        .bytes()
        .map(|(_, b)| b)
        .collect()
}

#[test]
fn real_file_stream_with_running_status_decodes_to_the_song_and_is_shorter() {
    let song = Song::parse(&read("mma-midi-inc-frankie.mid")).unwrap();
    let with = stream_bytes(&song, RunningStatus::On);
    let without = stream_bytes(&song, RunningStatus::Off);
    assert!(with.len() < without.len());
    assert_eq!(
        without.len(),
        song.events().iter().map(|e| e.bytes.len()).sum::<usize>()
    );
    assert_eq!(decode(&with), song_messages(&song));
    assert_eq!(decode(&without), song_messages(&song));
}

#[test]
fn stream_bytes_carry_their_message_time_in_order() {
    let song = Song::parse(&read("bach-invention-01.mid")).unwrap();
    let timed: Vec<(u64, u8)> = wire(song.messages(), RunningStatus::On).bytes().collect();
    assert!(timed.windows(2).all(|w| w[0].0 <= w[1].0));
    assert_eq!(
        timed.last().unwrap().0,
        song.events().last().unwrap().time_us
    );
}

#[derive(Clone, Debug)]
enum Ev {
    Channel(u8, u8, u8, u8), // kind 0..7, channel, d1, d2
    SysEx(Vec<u8>),
}

fn ev_strategy() -> impl Strategy<Value = (u32, Ev)> {
    let channel =
        (0u8..7, 0u8..16, 0u8..128, 0u8..128).prop_map(|(k, c, a, b)| Ev::Channel(k, c, a, b));
    let sysex = proptest::collection::vec(0u8..128, 0..20).prop_map(Ev::SysEx);
    (
        prop_oneof![Just(0u32), 0u32..1000],
        prop_oneof![8 => channel, 1 => sysex],
    )
}

/// One track's bytes, optionally written with running status.
fn track_bytes(events: &[(u32, Ev)], file_running_status: bool) -> Vec<u8> {
    let mut data = Vec::new();
    let mut running = None;
    for (delta, ev) in events {
        data.extend(vlq(*delta));
        match ev {
            Ev::Channel(kind, ch, a, b) => {
                let status = (0x80 + (kind << 4)) | ch;
                if !(file_running_status && running == Some(status)) {
                    data.push(status);
                }
                running = Some(status);
                data.push(*a);
                if !matches!(status & 0xF0, 0xC0 | 0xD0) {
                    data.push(*b);
                }
            }
            Ev::SysEx(body) => {
                running = None;
                data.push(0xF0);
                data.extend(vlq(body.len() as u32 + 1));
                data.extend(body);
                data.push(0xF7);
            }
        }
    }
    data
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn running_status_stream_decodes_back_to_exactly_the_songs_messages(
        tracks in proptest::collection::vec(proptest::collection::vec(ev_strategy(), 0..40), 1..4),
        file_running_status in any::<bool>(),
    ) {
        // Build the file by hand (the helper adds End of Track).
        let mut file = smf(1, 96, &[]);
        file[10..12].copy_from_slice(&(tracks.len() as u16).to_be_bytes());
        for t in &tracks {
            let mut data = track_bytes(t, file_running_status);
            data.extend([0, 0xFF, 0x2F, 0]);
            file.extend(b"MTrk");
            file.extend((data.len() as u32).to_be_bytes());
            file.extend(data);
        }
        let song = Song::parse(&file).unwrap();
        let count: usize = tracks.iter().map(Vec::len).sum();
        prop_assert_eq!(song.events().len(), count);
        let want = song_messages(&song);
        prop_assert_eq!(want.len(), count);
        prop_assert_eq!(decode(&stream_bytes(&song, RunningStatus::On)), want.clone());
        prop_assert_eq!(decode(&stream_bytes(&song, RunningStatus::Off)), want);
    }
}
