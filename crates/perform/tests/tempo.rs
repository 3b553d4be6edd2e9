//! The tempo changes mid-piece without planning the song again: every note is played exactly
//! once and in order, and score time stays continuous.

use std::path::PathBuf;
use std::sync::Arc;

use orch_perform::{
    perform, song_events, thesis_config, Control, Link, Live, MidiRecording, Setup, Tempo,
};
use orch_seq::{Song, VirtualClock};

#[test]
fn a_tempo_change_mid_piece_plays_every_note_once_in_order() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    let song = Song::parse(&std::fs::read(dir.join("bach-invention-01.mid")).unwrap()).unwrap();
    let setup = Setup {
        config: thesis_config(),
        sim: orch_sim::SimConfig::thesis(),
        compensation: true,
        tempo: Tempo::NORMAL,
        link: Link::Din,
    };
    let control: Arc<Control> = Control::new();
    let mut changed = false;
    let mut last_song_us = 0u64;
    let mut jumps = Vec::new();
    let mut live = |l: &Live| {
        // Score time never goes back.
        assert!(
            l.song_us + 1 >= last_song_us,
            "{} after {last_song_us}",
            l.song_us
        );
        jumps.push(l.song_us.saturating_sub(last_song_us));
        last_song_us = l.song_us;
        if !changed && l.song_us > 10_000_000 {
            control.set_tempo(Tempo::new(1.5).unwrap());
            changed = true;
        }
    };
    let mut out = MidiRecording::default();
    let played = perform(
        &setup,
        song_events(&song),
        song.notes(),
        Some(&mut out),
        &mut VirtualClock::new(),
        Some(&control),
        Some(&mut live),
    )
    .unwrap();
    assert!(changed);
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.unmatched, 0);
    assert_eq!(r.outcomes.dropped.stopped, 0);
    // Every Note-On of the score went out once, in the score's order.
    let sent: Vec<u8> = out
        .sent
        .iter()
        .scan(0u8, |status, (_, b)| {
            let (st, data) = if b[0] >= 0x80 {
                (b[0], &b[1..])
            } else {
                (*status, &b[..])
            };
            if b[0] < 0xF8 {
                *status = st;
            }
            Some((st, data.to_vec()))
        })
        .filter(|(st, d)| st & 0xF0 == 0x90 && d.len() == 2 && d[1] > 0)
        .map(|(_, d)| d[0])
        .collect();
    let score: Vec<u8> = song
        .events()
        .iter()
        .filter_map(|e| e.bytes.note_on().map(|(_, n, _)| n))
        .collect();
    assert_eq!(sent.len(), score.len());
    // Every key has the same press lead here, so the presses go out in the score's order.
    assert_eq!(sent, score);
    // The second half went faster: 40 ms steps of wall time now cover 60 ms of score.
    assert!(
        jumps.iter().any(|&j| j >= 59_000),
        "{:?}",
        &jumps[jumps.len() - 3..]
    );
    // In order per key (notes of one key never swap).
    for key in 36..=96u8 {
        let a: Vec<usize> = sent
            .iter()
            .enumerate()
            .filter(|(_, &n)| n == key)
            .map(|(i, _)| i)
            .collect();
        let b = score.iter().filter(|&&n| n == key).count();
        assert_eq!(a.len(), b, "key {key}");
    }
}
