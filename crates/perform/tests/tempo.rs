//! The tempo changes mid-piece without planning the song again: every note is played exactly
//! once and in order, and score time stays continuous.

use std::path::PathBuf;
use std::sync::Arc;

use orch_perform::{song_events, Control, Link, Live, MidiRecording, Performer, Setup, Tempo};
use orch_seq::Song;

mod common;
use common::{note_ons, note_ons_at, ActAt};

#[test]
fn a_tempo_change_mid_piece_plays_every_note_once_in_order() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    let song = Song::parse(&std::fs::read(dir.join("bach-invention-01.mid")).unwrap()).unwrap();
    let setup = Setup::thesis().with_link(Link::Din);
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
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .control(&control)
        .midi(&mut out)
        .live(&mut live)
        .run()
        .unwrap();
    assert!(changed);
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.unmatched, 0);
    assert_eq!(r.outcomes.dropped.stopped, 0);
    // Every Note-On of the score went out once, in the score's order.
    let sent = note_ons(&out);
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

/// Plays the invention over `link` (to a MIDI recording, or on the virtual robot itself),
/// pausing for a second at 5 s of score time: every key is up through the pause, score time
/// holds, and every note still goes out once, in order.
fn pause_and_resume(link: Link, midi: bool) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    let song = Song::parse(&std::fs::read(dir.join("bach-invention-01.mid")).unwrap()).unwrap();
    let setup = Setup::thesis().with_link(link);
    let control: Arc<Control> = Control::new();
    let mut paused_views = 0;
    let mut asked = false;
    let mut at_pause = None;
    let mut last_song_us = 0u64;
    let mut after = Vec::new();
    let mut live = |l: &Live| {
        assert!(l.song_us + 1 >= last_song_us, "score time went back");
        last_song_us = l.song_us;
        if l.paused {
            let held = *at_pause.get_or_insert(l.song_us);
            assert_eq!(l.song_us, held, "score time moved in the pause");
            paused_views += 1;
            // After the first wake every key is up (a strike may first be held its shortest
            // sounding press).
            if paused_views > 1 {
                assert!(l.keys_down.iter().all(|&d| !d), "a key down in the pause");
            }
            if paused_views == 25 {
                control.resume();
            }
        } else if !asked && l.song_us > 5_000_000 {
            assert!(l.keys_down.iter().any(|&d| d), "the test wants keys down");
            control.pause();
            asked = true;
        } else if at_pause.is_some() {
            after.push(l.song_us);
        }
    };
    let mut out = MidiRecording::default();
    let mut performer = Performer::new(&setup, song_events(&song), song.notes())
        .control(&control)
        .live(&mut live);
    if midi {
        performer = performer.midi(&mut out);
    }
    let played = performer.run().unwrap();
    assert_eq!(paused_views, 25);
    let held = at_pause.unwrap();
    // It went on from where it paused: the first view after comes within two wakes (80 ms)
    // of score time, not the second of the pause.
    assert!(
        after[0] >= held && after[0] <= held + 81_000,
        "{held} {:?}",
        &after[..3]
    );
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.outcomes.dropped.stopped, 0);
    if midi {
        // All Notes Off on every channel at the pause, then no Note-On for the second it lasts.
        let offs: Vec<u64> = out
            .sent
            .iter()
            .filter(|(_, b)| b.ends_with(&[123, 0]))
            .map(|(t, _)| *t)
            .collect();
        // 16 at the pause and 16 at the end.
        assert_eq!(offs.len(), 32, "{offs:?}");
        let paused_at = offs[0];
        let ons = note_ons_at(&out);
        let next = ons.iter().find(|(t, _)| *t >= paused_at).unwrap().0;
        assert!(next - paused_at >= 960_000, "{paused_at} {next}");
        let score: Vec<u8> = song
            .events()
            .iter()
            .filter_map(|e| e.bytes.note_on().map(|(_, n, _)| n))
            .collect();
        assert_eq!(note_ons(&out), score);
    } else {
        assert_eq!(r.strikes + r.outcomes.joined + r.outcomes.unison, r.notes);
    }
}

#[test]
fn a_pause_releases_every_key_and_the_rest_plays_once_after_it() {
    pause_and_resume(Link::Din, true);
    pause_and_resume(Link::Direct, false);
}

/// A tempo change after a press went out early: it is not taken back (the note strikes
/// once, when it was going to), and the note the change made late is counted late.
#[test]
fn a_change_after_an_early_press_counts_the_note_it_made_late() {
    // Three quarter notes at 60 BPM: at 0, 1 and 2 s, 100 ms each (48 ticks).
    let tempo = testkit::smf::tempo(1_000_000);
    let mut events: Vec<(u32, &[u8])> = vec![(0, &tempo)];
    let notes: Vec<([u8; 3], [u8; 3])> = (0..3u8)
        .map(|i| ([0x90, 60 + i, 100], [0x80, 60 + i, 0]))
        .collect();
    for (i, (on, off)) in notes.iter().enumerate() {
        events.push((if i == 0 { 0 } else { 432 }, on));
        events.push((48, off));
    }
    let smf = testkit::smf::one_track(&events);
    let song = Song::parse(&smf).unwrap();
    let setup = Setup::thesis();
    let lead = setup.rules().press_lead_us[24 + 1];
    let control: Arc<Control> = Control::new();
    // The second note's press goes out `lead` before 1 s; three times as fast from then.
    let mut clock = ActAt::new(&control, 1_000_000 - lead, |c: &Control| {
        c.set_tempo(Tempo::new(3.0).unwrap())
    });
    let mut live = |_: &Live| {};
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .clock(&mut clock)
        .control(&control)
        .live(&mut live)
        .run()
        .unwrap();
    assert!(clock.done());
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.strikes, 3, "every note struck once");
    assert_eq!(r.outcomes.on_time, 2, "{:?}", played.records);
    // The second sounds when its press (sent before the change) makes it sound: the faster
    // tempo wanted it two thirds of the lead sooner.
    assert_eq!(r.outcomes.late, 1, "{:?}", played.records);
    let by = match played.records[1].outcome {
        orch_perform::Outcome::Late { by_us } => i64::from(by_us),
        o => panic!("{o:?}"),
    };
    assert!((by - lead as i64 * 2 / 3).abs() <= 1_000, "{by} {lead}");
}
