//! The real files of ../shared/midi: every well-formed one plays as mido counts it, every
//! damaged one is refused, and no cut or scribble makes the parser panic.

mod common;

use std::sync::OnceLock;

use common::{manifest, read, Row};
use orch_seq::Song;

/// Every well-formed row, parsed once (the corpus holds 10-minute files with 20 000 notes).
fn parsed() -> &'static Vec<(Row, Result<Song, orch_seq::SeqError>)> {
    static PARSED: OnceLock<Vec<(Row, Result<Song, orch_seq::SeqError>)>> = OnceLock::new();
    PARSED.get_or_init(|| {
        manifest()
            .into_iter()
            .filter(|r| !r.file.starts_with("bad-"))
            .map(|r| {
                let song = Song::parse(&read(&r.file));
                (r, song)
            })
            .collect()
    })
}

#[test]
fn every_well_formed_corpus_file_parses_with_manifest_note_count() {
    let mut failures = Vec::new();
    for (row, song) in parsed() {
        match song {
            Err(e) => failures.push(format!("{}: refused: {e}", row.file)),
            Ok(song) => {
                let expected = row.note_ons.expect("note_ons column");
                if song.notes() != expected {
                    failures.push(format!(
                        "{}: {} notes, manifest {expected}",
                        row.file,
                        song.notes()
                    ));
                }
            }
        }
    }
    assert!(parsed().len() > 100, "corpus rows: {}", parsed().len());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_well_formed_corpus_file_lasts_as_manifest_says() {
    let mut failures = Vec::new();
    let mut worst = (0.0f64, String::new());
    for (row, song) in parsed() {
        let Ok(song) = song else { continue };
        let expected = row.seconds.expect("seconds column");
        let got = song.duration_us() as f64 / 1e6;
        if (got - expected).abs() > worst.0 {
            worst = ((got - expected).abs(), row.file.clone());
        }
        if (got - expected).abs() > 0.5 {
            failures.push(format!("{}: {got:.3} s, manifest {expected} s", row.file));
        }
    }
    eprintln!(
        "largest difference from the manifest: {:.3} s ({})",
        worst.0, worst.1
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn corpus_files_mido_reads_are_exactly_the_ones_we_read() {
    for row in manifest() {
        let ok = Song::parse(&read(&row.file)).is_ok();
        assert_eq!(
            ok, row.mido_ok,
            "{}: ours {ok}, mido {}",
            row.file, row.mido_ok
        );
    }
}

#[test]
fn every_bad_corpus_file_is_an_error_with_a_message() {
    let bad: Vec<Row> = manifest()
        .into_iter()
        .filter(|r| r.file.starts_with("bad-"))
        .collect();
    assert!(bad.len() >= 5);
    for row in bad {
        let err = Song::parse(&read(&row.file)).expect_err(&row.file);
        let msg = err.to_string();
        assert!(msg.len() > 10, "{}: {msg}", row.file);
        eprintln!("{}: {msg}", row.file);
    }
}

#[test]
fn corpus_events_are_in_time_order_with_times_from_the_tempo_map() {
    for (row, song) in parsed() {
        let Ok(song) = song else { continue };
        let ev = song.events();
        for w in ev.windows(2) {
            assert!(
                w[0].tick <= w[1].tick && w[0].time_us <= w[1].time_us,
                "{}",
                row.file
            );
        }
        for e in ev.iter().step_by(97) {
            assert_eq!(song.time_at_tick(e.tick), e.time_us, "{}", row.file);
        }
        assert!(song.duration_us() >= ev.last().map_or(0, |e| e.time_us));
    }
}

#[test]
fn truncating_real_files_at_every_97th_byte_never_panics() {
    for file in [
        "bach-bwv846-prelude.mid",
        "mma-midi-inc-frankie.mid",
        "timidity-test-sample.mid",
        "smpte-25fps-joplin.mid",
    ] {
        let bytes = read(file);
        for cut in (0..bytes.len()).step_by(97) {
            // A cut file has a chunk longer than what is left: always an error.
            assert!(Song::parse(&bytes[..cut]).is_err(), "{file} cut at {cut}");
        }
    }
}

#[test]
fn truncating_inside_a_track_with_patched_lengths_never_panics() {
    // Cut the last track and fix its declared length, so the damage reaches the event reader.
    let bytes = read("mma-midi-inc-frankie.mid");
    let last_mtrk = bytes.windows(4).rposition(|w| w == b"MTrk").unwrap();
    for cut in (last_mtrk + 8..bytes.len()).step_by(7) {
        let mut b = bytes[..cut].to_vec();
        let len = (cut - last_mtrk - 8) as u32;
        b[last_mtrk + 4..last_mtrk + 8].copy_from_slice(&len.to_be_bytes());
        let _ = Song::parse(&b);
    }
}
