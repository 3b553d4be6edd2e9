//! Every well-formed file of the shared corpus, performed on the virtual robot: the account
//! adds up, every struck note found its sound, compensation lands notes on time, and the
//! streaming planner equals planning the whole song first.

use orch_perform::{song_events, Link, Planner, Played, Setup, Tempo};
use orch_seq::Song;

mod common;

fn corpus() -> Vec<(String, Song)> {
    let dir = common::shared_midi();
    let manifest = std::fs::read_to_string(dir.join("MANIFEST.tsv"))
        .expect("the shared MIDI corpus (../shared/midi) is beside the checkout");
    let mut out = Vec::new();
    for line in manifest.lines().skip(1) {
        let file = line.split('\t').next().unwrap_or("");
        let Ok(bytes) = std::fs::read(dir.join(file)) else {
            continue;
        };
        if let Ok(song) = Song::parse(&bytes) {
            out.push((file.to_string(), song));
        }
    }
    assert!(out.len() > 80, "only {} corpus files parse", out.len());
    out
}

fn setup(compensation: bool, link: Link) -> Setup {
    common::setup(link).with_compensation(compensation)
}

fn play(setup: &Setup, song: &Song) -> Played {
    common::render(setup, song_events(song), song.notes())
}

#[test]
fn every_corpus_file_adds_up_finds_every_sound_and_lands_on_time() {
    let s = setup(true, Link::Direct);
    let late_limit = 30.0;
    let mut all = orch_perform::Outcomes::default();
    for (file, song) in corpus() {
        let played = play(&s, &song);
        let r = played.report(None);
        assert_eq!(r.notes, song.notes() as u64, "{file}");
        assert!(r.adds_up(), "{file}: {:?}", r);
        assert_eq!(r.unmatched, 0, "{file}");
        assert_eq!(r.outcomes.early, 0, "{file}");
        assert_eq!(r.strikes, r.outcomes.on_time + r.outcomes.late, "{file}");
        assert!(r.onset_ms.median <= 0.1, "{file}: {:?}", r.onset_ms);
        assert!(r.onset_ms.max <= late_limit, "{file}: {:?}", r.onset_ms);
        let o = r.outcomes;
        all.on_time += o.on_time;
        all.late += o.late;
        all.unison += o.unison;
        all.joined += o.joined;
        all.dropped.too_fast += o.dropped.too_fast;
        all.dropped.power += o.dropped.power;
    }
    eprintln!("corpus: {all:?}");
}

/// The same files on the 61 keys of four PCA9685 boards (velocity as strike strength, the
/// default curve and mechanics): the account adds up with `too_soft` among the outcomes, every
/// struck note's loudness is within 2 velocity steps of its velocity in the median, and
/// compensation by velocity lands them on time.
#[test]
fn every_corpus_file_on_pwm_boards_adds_up_and_sounds_at_its_velocity() {
    let s = common::pwm_setup(orch_sim::MechanicsConfig::default(), true);
    let mut all = orch_perform::Outcomes::default();
    let mut medians = Vec::new();
    for (file, song) in corpus() {
        let played = play(&s, &song);
        let r = played.report(None);
        assert_eq!(r.notes, song.notes() as u64, "{file}");
        assert!(r.adds_up(), "{file}: {:?}", r);
        assert_eq!(r.unmatched, 0, "{file}");
        assert_eq!(r.outcomes.early, 0, "{file}");
        assert_eq!(
            r.outcomes.dropped.too_soft, 0,
            "{file}: the curve matches the keys"
        );
        if r.strikes > 0 {
            let v = r.velocity_error.expect("struck notes on PWM keys");
            assert!(v.median <= 2, "{file}: {v:?}");
            // A chord on one board is one write of the run of channels that changed, every
            // channel switched at its STOP: up to 596 bit-times (0.6 ms at 1 MHz) where the
            // planner counts one channel's 56. Within the 1 ms of on time, always.
            assert!(r.onset_ms.median <= 0.6, "{file}: {:?}", r.onset_ms);
            medians.push(r.onset_ms.median);
        }
        // The note-by-note account says the same, note by note.
        let account = played.account(|_, _| (1, 1));
        assert_eq!(account.len() as u64, r.notes, "{file}");
        let count = |name: &str| account.iter().filter(|l| l.outcome == name).count() as u64;
        let o = r.outcomes;
        assert_eq!(
            [
                count("on_time"),
                count("late"),
                count("unison"),
                count("joined"),
                count("dropped")
            ],
            [o.on_time, o.late, o.unison, o.joined, o.dropped.total()],
            "{file}"
        );
        let soft = account
            .iter()
            .filter(|l| l.reason == Some("too_soft"))
            .count() as u64;
        assert_eq!(soft, o.dropped.too_soft, "{file}");
        all.on_time += o.on_time;
        all.late += o.late;
        all.dropped.power += o.dropped.power;
    }
    medians.sort_by(f64::total_cmp);
    eprintln!(
        "corpus on PCA9685 boards: {all:?}; files' median onset error: median {} ms, largest {} ms",
        medians[medians.len() / 2],
        medians[medians.len() - 1]
    );
}

#[test]
fn without_compensation_every_struck_note_is_late_by_its_press_delay() {
    let s = setup(false, Link::Direct);
    for (file, song) in corpus().into_iter().take(20) {
        let r = play(&s, &song).report(None);
        // Plain score timing: a note shorter than a key's shortest sounding press makes no
        // sound, and says so (unmatched), which compensation avoids.
        assert!(r.adds_up(), "{file}");
        if r.strikes > 0 {
            assert!(r.onset_ms.median >= 15.0, "{file}: {:?}", r.onset_ms);
        }
    }
}

#[test]
fn the_streaming_planner_equals_planning_the_whole_song() {
    let s = setup(true, Link::Direct);
    for (file, song) in corpus() {
        let mut streaming = Planner::new(song_events(&song), s.rules(), 1_000, Tempo::NORMAL);
        let mut whole = Planner::new(song_events(&song), s.rules(), 1_000, Tempo::NORMAL).eager();
        let mut n = 0;
        loop {
            let (a, b) = (streaming.next_planned(), whole.next_planned());
            assert_eq!(a, b, "{file}: send {n} differs");
            if a.is_none() {
                break;
            }
            n += 1;
        }
        let (a, b) = (streaming.stats(), whole.stats());
        assert_eq!(
            orch_perform::PlanStats { peak_queue: 0, ..a },
            orch_perform::PlanStats { peak_queue: 0, ..b },
            "{file}"
        );
        // Bounded lookahead: the queue never holds the whole song.
        if song.notes() > 2_000 {
            assert!(
                streaming.stats().peak_queue < song.events().len() / 4,
                "{file}: {} queued of {}",
                streaming.stats().peak_queue,
                song.events().len()
            );
        }
    }
}
