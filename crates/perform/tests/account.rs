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
        let bar_beat = |t_ms: f64| song.bar_beat((t_ms * 1000.0).round() as u64);
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
