//! The indexed account: the same lines as the account, each tied to its record, and (with no
//! jump) a record's index is its note's place among the song's Note-Ons, so a line finds its
//! Note-Off in `Song::note_spans`.

use orch_perform::{song_events, Link};

mod common;

#[test]
fn account_indexed_ties_each_line_to_its_record_and_note_span() {
    for file in ["bach-invention-01.mid", "bach-bwv66-6-chorale.mid"] {
        let song = common::corpus_song(file);
        let played = common::render(
            &common::setup(Link::Direct),
            song_events(&song),
            song.notes(),
        );
        let bar_beat = |_: usize, t_ms: f64| song.bar_beat((t_ms * 1000.0).round() as u64);
        let indexed = played.account_indexed(bar_beat);
        let plain = played.account(bar_beat);
        assert_eq!(
            indexed.iter().map(|(_, l)| l.clone()).collect::<Vec<_>>(),
            plain,
            "{file}"
        );
        let spans = song.note_spans();
        assert_eq!(spans.len(), indexed.len(), "{file}");
        let start = played.start_us as i64;
        for (i, line) in &indexed {
            let r = &played.records[*i];
            assert_eq!((r.note, r.channel + 1), (line.note, line.channel), "{file}");
            let s = &spans[*i];
            assert_eq!(
                (s.note, s.channel + 1),
                (line.note, line.channel),
                "{file} #{i}"
            );
            assert_eq!(s.on_us as i64, r.score_at_us - start, "{file} #{i}");
            assert!(s.off_us >= s.on_us, "{file} #{i}");
        }
    }
}

/// A virtual clock that wakes `late_us` late at the first deadline at or after `at_us`, as a
/// busy host wakes a real one.
struct WakesLate {
    inner: orch_seq::VirtualClock,
    at_us: u64,
    late_us: u64,
    done: bool,
}

impl orch_seq::Clock for WakesLate {
    fn now_us(&self) -> u64 {
        self.inner.now_us()
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        if !self.done && deadline_us >= self.at_us {
            self.done = true;
            return self.inner.wait_until(deadline_us + self.late_us);
        }
        self.inner.wait_until(deadline_us)
    }

    fn lateness(&self) -> orch_seq::Lateness {
        self.inner.lateness()
    }
}

#[test]
fn a_note_sent_late_by_the_clock_says_how_late_and_the_others_none() {
    // Quarters at 120 BPM; the host wakes 7 ms late to send the fourth's Note-On (when the
    // virtual clock sends it).
    let song = testkit::smf::quarters_smf(8, 120.0);
    let song = orch_seq::Song::parse(&song).unwrap();
    let setup = common::setup(Link::Direct);
    let fast = common::render(&setup, song_events(&song), song.notes());
    let mut clock = WakesLate {
        inner: orch_seq::VirtualClock::new(),
        at_us: fast.records[3].sent_us().unwrap(),
        late_us: 7_000,
        done: false,
    };
    let played = orch_perform::Performer::new(&setup, song_events(&song), song.notes())
        .clock(&mut clock)
        .run()
        .unwrap();
    let bar_beat = |_: usize, t_ms: f64| song.bar_beat((t_ms * 1000.0).round() as u64);
    let late: Vec<f64> = played
        .account(bar_beat)
        .iter()
        .map(|l| l.sent_late_ms.expect("each note sent in real time"))
        .collect();
    assert_eq!(late, [0.0, 0.0, 0.0, 7.0, 0.0, 0.0, 0.0, 0.0]);
    // The same send among every message's.
    let each = played.lateness_us.as_ref().unwrap();
    assert_eq!(each.iter().filter(|&&l| l > 0).count(), 1, "{each:?}");
    // On the virtual clock (no clock asked for), nothing is measured.
    assert!(fast
        .account(bar_beat)
        .iter()
        .all(|l| l.sent_late_ms.is_none()));
    assert!(fast.lateness_us.is_none());
}
