//! A jump mid-piece (`Control::jump_to`): every key released at the jump on every output, each
//! note after the target played once and in order, none between, and the account adding up.

use std::sync::Arc;

use orch_perform::{song_events, Control, Link, Live, MidiRecording, Performer, Played};
use orch_seq::Song;

mod common;
use common::{corpus_song, note_ons_at, setup, ActAt};

/// The score's Note-Ons: (score time, note number), in order.
fn score_notes(song: &Song) -> Vec<(u64, u8)> {
    song.events()
        .iter()
        .filter_map(|e| e.bytes.note_on().map(|(_, n, _)| (e.time_us, n)))
        .collect()
}

/// What a jump did, seen from outside.
struct Run {
    played: Played,
    out: MidiRecording,
    /// Score time of each view after the jump was asked, and whether every key was up.
    after: Vec<(u64, bool)>,
}

/// Plays the invention over `link`, asking at `at_us` of score time for a jump to `target_us`.
fn jump(link: Link, midi: bool, at_us: u64, target_us: u64) -> Run {
    let song = corpus_song("bach-invention-01.mid");
    let control: Arc<Control> = Control::new();
    control.poll_every(5_000);
    let mut asked = false;
    let mut after = Vec::new();
    let mut live = |l: &Live| {
        if asked {
            after.push((l.song_us, l.keys_down.iter().all(|&d| !d)));
        } else if l.song_us > at_us {
            assert!(l.keys_down.iter().any(|&d| d), "the test wants keys down");
            control.jump_to(target_us);
            asked = true;
        }
    };
    let mut out = MidiRecording::default();
    let setup = setup(link);
    let mut performer = Performer::new(&setup, song_events(&song), song.notes())
        .control(&control)
        .live(&mut live);
    if midi {
        performer = performer.midi(&mut out);
    }
    let played = performer.run().unwrap();
    assert!(asked);
    Run { played, out, after }
}

/// The checks on a recording of the MIDI sent: All Notes Off and All Sound Off on every
/// channel at the jump; before it, Note-Ons of a prefix of the score; from it, exactly the
/// score's notes from the target on, once each and in order. Returns (Note-Ons before the
/// jump, Note-Ons after it).
fn check_recording(song: &Song, out: &MidiRecording, target_us: u64) -> (usize, usize) {
    // Each message with its status (the recording is under running status).
    let mut status = 0u8;
    let full: Vec<(u64, Vec<u8>)> = out
        .sent
        .iter()
        .map(|(t, b)| {
            if b[0] >= 0x80 {
                status = b[0];
                (*t, b.clone())
            } else {
                (*t, [&[status][..], b].concat())
            }
        })
        .collect();
    let at = |cc: u8| -> Vec<(u64, u8)> {
        full.iter()
            .filter(|(_, b)| b[0] & 0xF0 == 0xB0 && b[1..] == [cc, 0])
            .map(|(t, b)| (*t, b[0] & 0x0F))
            .collect()
    };
    let (offs, sound_offs) = (at(123), at(120));
    // 16 at the jump and 16 at the end.
    assert_eq!(offs.len(), 32, "{offs:?}");
    let jumped_at = offs[0].0;
    let channels = |v: &[(u64, u8)]| {
        let mut c: Vec<u8> = v
            .iter()
            .filter(|(t, _)| *t == jumped_at)
            .map(|x| x.1)
            .collect();
        c.sort_unstable();
        c
    };
    assert_eq!(channels(&offs), (0..16).collect::<Vec<u8>>());
    assert_eq!(channels(&sound_offs), (0..16).collect::<Vec<u8>>());
    let score = score_notes(song);
    let ons = note_ons_at(out);
    let before: Vec<u8> = ons
        .iter()
        .filter(|(t, _)| *t < jumped_at)
        .map(|x| x.1)
        .collect();
    let after: Vec<u8> = ons
        .iter()
        .filter(|(t, _)| *t >= jumped_at)
        .map(|x| x.1)
        .collect();
    let prefix: Vec<u8> = score[..before.len()].iter().map(|x| x.1).collect();
    assert_eq!(
        before, prefix,
        "before the jump, the score's first notes in order"
    );
    let from_target: Vec<u8> = score
        .iter()
        .filter(|(t, _)| *t >= target_us)
        .map(|x| x.1)
        .collect();
    assert_eq!(
        after, from_target,
        "after the jump, every note from the target once"
    );
    (before.len(), after.len())
}

#[test]
fn a_jump_forward_releases_every_key_and_plays_each_note_after_the_target_once_in_order() {
    let song = corpus_song("bach-invention-01.mid");
    let (at, target) = (5_000_000, 12_000_000);
    let run = jump(Link::Din, true, at, target);
    let (before, after) = check_recording(&song, &run.out, target);
    let r = run.played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!((r.jumps, r.replayed), (1, 0));
    assert_eq!(r.outcomes.dropped.stopped, 0);
    // Every note is played or skipped, and the skipped are exactly those between.
    assert_eq!(r.outcomes.skipped as usize, song.notes() - before - after);
    let between = score_notes(&song)
        .iter()
        .filter(|(t, _)| (at..target).contains(t))
        .count();
    assert!(r.outcomes.skipped as usize >= between - 2, "{r:?}");
    // Score time is continuous from the target: the first view after the jump shows the
    // target (through its lead-in), and it never goes back.
    assert_eq!(run.after[0].0, target, "{:?}", &run.after[..3]);
    for w in run.after.windows(2) {
        assert!(w[1].0 + 1 >= w[0].0, "score time went back: {w:?}");
    }
}

#[test]
fn a_jump_releases_every_key_of_the_virtual_robot_before_the_next_strike() {
    let song = corpus_song("bach-invention-01.mid");
    let run = jump(Link::Direct, false, 5_000_000, 12_000_000);
    // Views every 5 ms: within the lead-in (the first strike after the target comes a
    // re-strike gap after the release at the earliest), a view shows every key up.
    assert!(
        run.after[..10].iter().any(|&(_, up)| up),
        "{:?}",
        &run.after[..10]
    );
    let r = run.played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert!(r.outcomes.skipped > 0);
    let o = r.outcomes;
    assert_eq!(
        r.strikes + o.joined + o.unison + o.skipped,
        song.notes() as u64,
        "{r:?}"
    );
}

#[test]
fn a_jump_back_plays_the_notes_after_the_target_again_each_once_more() {
    let song = corpus_song("bach-invention-01.mid");
    let target = 2_000_000;
    let run = jump(Link::Din, true, 8_000_000, target);
    let (before, after) = check_recording(&song, &run.out, target);
    let r = run.played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.jumps, 1);
    let score = score_notes(&song);
    let again = score[..before].iter().filter(|(t, _)| *t >= target).count();
    // The notes played again are counted once more; the few read ahead and not sent when
    // it jumped are the skipped ones.
    assert_eq!(r.replayed, again as u64 + r.outcomes.skipped, "{r:?}");
    assert_eq!(before + after, song.notes() + again);
    assert_eq!(r.outcomes.dropped.stopped, 0);
}

/// The channel's state at the target is chased: program, controllers and pedal as the score
/// has them there, sent at the jump; a pedal the score has let up by then is sent up.
#[test]
fn a_jump_chases_the_program_controllers_and_pedals_at_the_target() {
    use orch_perform::{Planned, Planner, ScoreEvent, Tempo};
    use orch_seq::WireBytes;
    let ev = |t: u64, b: &[u8]| ScoreEvent {
        score_us: t,
        bytes: WireBytes::new(b),
    };
    let score = vec![
        ev(0, &[0xC1, 5]),
        ev(0, &[0xB1, 64, 127]),
        ev(100_000, &[0xB1, 7, 90]),
        // Reset All Controllers: volume and pedal reset, the program kept.
        ev(200_000, &[0xB1, 121, 0]),
        ev(250_000, &[0xB1, 64, 127]),
        ev(300_000, &[0xB1, 7, 80]),
        ev(500_000, &[0x91, 60, 100]),
        ev(1_000_000, &[0x81, 60, 0]),
        ev(1_500_000, &[0xB1, 64, 0]),
        ev(2_000_000, &[0x91, 62, 100]),
        ev(2_500_000, &[0x81, 62, 0]),
    ];
    let chased = |target: u64| -> (Vec<Vec<u8>>, u32, Vec<Vec<u8>>) {
        let mut p = Planner::new(
            score.clone().into_iter(),
            setup(Link::Direct).rules(),
            0,
            Tempo::NORMAL,
        );
        // Play into the piece, then jump.
        while p.peek_time().is_some_and(|t| t < 400_000) {
            p.next_planned();
        }
        let jumped = p.jump(score.clone().into_iter(), 400_000, target);
        assert!(jumped.unsent.iter().all(|s| s.note == 0), "{jumped:?}");
        let mut at_jump = Vec::new();
        let mut later = Vec::new();
        while let Some(Planned::Send { at_us, bytes, .. }) = p.next_planned() {
            if at_us == 400_000 {
                at_jump.push(bytes.to_vec());
            } else {
                later.push(bytes.to_vec());
            }
        }
        (at_jump, p.notes_read(), later)
    };
    // At 1.2 s: program 5, volume 80 (after the reset), the pedal still down; note 60 (begun
    // before the target) is not restarted and its Note-Off, a no-op, goes on.
    let (at_jump, _, later) = chased(1_200_000);
    assert_eq!(
        at_jump,
        vec![
            vec![0xC1, 5],
            vec![0xB1, 7, 80],
            vec![0xB1, 64, 127],
            vec![0xB1, 66, 0]
        ]
    );
    assert_eq!(later[0], vec![0xB1, 64, 0]);
    assert!(!later.contains(&vec![0x91, 60, 100]));
    // At 1.8 s the pedal is up.
    let (at_jump, notes_read, _) = chased(1_800_000);
    assert!(at_jump.contains(&vec![0xB1, 64, 0]), "{at_jump:?}");
    assert_eq!(notes_read, 2);
}

/// Several robots play one score on one control (`--out` given twice): each takes the jump
/// (and a tempo), not only the first to look.
#[test]
fn every_robot_sharing_a_control_takes_the_jump_and_the_tempo() {
    let song = corpus_song("bach-invention-01.mid");
    let control: Arc<Control> = Control::new();
    control.jump_to(song.bar_start_us(10).unwrap());
    control.set_tempo(orch_perform::Tempo::new(2.0).unwrap());
    for robot in 0..2 {
        let played = Performer::new(&setup(Link::Direct), song_events(&song), song.notes())
            .control(&control)
            .run()
            .unwrap();
        let r = played.report(None);
        assert_eq!(r.jumps, 1, "robot {robot}");
        assert!(r.outcomes.skipped > 50, "robot {robot}: {r:?}");
        assert_eq!(
            control.time_map().unwrap().tempo().get(),
            2.0,
            "robot {robot}"
        );
    }
}

/// A jump asked right after a press went out early: the key is let go only once the strike
/// has sounded (as at the end of a song), so the note sent is heard, not cut to a click.
#[test]
fn a_jump_right_after_a_press_lets_that_strike_sound() {
    let song = corpus_song("bach-invention-01.mid");
    let setup = setup(Link::Direct);
    let score = score_notes(&song);
    let k = score.iter().position(|(t, _)| *t >= 3_000_000).unwrap();
    let key = usize::from(score[k].1 - 36);
    let lead = setup.rules().press_lead_us[key];
    let control: Arc<Control> = Control::new();
    let mut clock = ActAt::new(&control, score[k].0 - lead, |c: &Control| {
        c.jump_to(10_000_000)
    });
    let mut live = |_: &Live| {};
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .clock(&mut clock)
        .control(&control)
        .live(&mut live)
        .run()
        .unwrap();
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.jumps, 1);
    assert_eq!(r.unmatched, 0, "{r:?}");
    assert!(
        matches!(
            played.records[k].outcome,
            orch_perform::Outcome::OnTime { .. }
        ),
        "{:?}",
        played.records[k]
    );
}
