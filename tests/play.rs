//! `orch play` end to end on the virtual robot, over the shared corpus of real MIDI files.

use std::path::{Path, PathBuf};

use orch::engine::Engine;
use orch::perform::{plan, sends, Options};
use orch::play::{load_song, render};
use orch::report::{onset_errors, Report};
use orch::robot::Robot;
use orch_seq::TempoScale;

fn corpus_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/midi");
    assert!(
        dir.join("MANIFEST.tsv").exists(),
        "the shared MIDI corpus is missing at {}",
        dir.display()
    );
    dir
}

/// (file, note-ons with velocity > 0) of every well-formed file in the MANIFEST.
fn well_formed() -> Vec<(PathBuf, u64)> {
    let dir = corpus_dir();
    let tsv = std::fs::read_to_string(dir.join("MANIFEST.tsv")).unwrap();
    let mut lines = tsv.lines();
    let head: Vec<&str> = lines.next().unwrap().split('\t').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (file, notes, bad) = (col("file"), col("note_ons"), col("notes"));
    lines
        .map(|l| l.split('\t').collect::<Vec<_>>())
        .filter(|r| r[bad].is_empty() && !r[file].starts_with("bad-"))
        .map(|r| (dir.join(r[file]), r[notes].parse().unwrap()))
        .collect()
}

fn options(compensation: bool) -> Options {
    Options {
        compensation,
        scale: TempoScale::new(1.0).unwrap(),
    }
}

#[test]
fn every_well_formed_corpus_file_plays_and_every_note_is_accounted_for() {
    let robot = Robot::thesis();
    let files = well_formed();
    assert!(files.len() > 50, "only {} files", files.len());
    for (path, note_ons) in files {
        let song = load_song(&path).unwrap();
        let out = render(&song, &robot, options(true)).unwrap();
        let report = Report::new(song.notes() as u64, &out, &out);
        assert_eq!(report.notes, note_ons, "{}", path.display());
        assert_eq!(
            u64::from(out.stats.note_ons),
            note_ons,
            "{}",
            path.display()
        );
        assert_eq!(
            report.accounted(),
            note_ons,
            "{}: {report:?}",
            path.display()
        );
        // Everything is released at the end.
        let last = out.performance.edges.iter().filter(|e| e.high).count();
        let falls = out.performance.edges.iter().filter(|e| !e.high).count();
        assert_eq!(last, falls, "{}: a pin left high", path.display());
    }
}

#[test]
fn unlimited_guard_and_no_mechanics_delay_sound_each_note_at_its_score_time_within_one_bus_write() {
    // No limit on hold, keys down, rest or silence. `min_press` is not a limit but the promise
    // that a zero-length note (on and off at one instant) still strikes: 1 ms here.
    let robot = Robot::from_toml(
        "[mechanics]\npress_delay = \"0ms\"\nrelease_delay = \"0ms\"\nmin_hold = \"0ms\"\n\
         [guard]\nmax_hold = \"off\"\nmax_keys_down = 255\nrestrike_gap = \"0ms\"\nmin_press = \"1ms\"\nwatchdog = \"off\"\n",
    )
    .unwrap();
    let write = robot.write_micros() / 1000.0;
    for (path, _) in well_formed() {
        let song = load_song(&path).unwrap();
        let out = render(&song, &robot, options(false)).unwrap();
        let writes = &out.performance.writes;
        for (note, error) in onset_errors(&out) {
            // The writes queued on the bus at that instant (a chord over several boards) come
            // one after the other; this note's own write is one of them.
            let at = note.score_us as f64 / 1e3;
            let first = writes.partition_point(|w| (w.start.as_nanos() as f64 / 1e6) < at - 1e-6);
            let queued = writes[first..]
                .iter()
                .take_while(|w| (w.start.as_nanos() as f64 / 1e6) < at + error)
                .count()
                .max(1);
            assert!(
                error >= -1e-6 && error <= queued as f64 * write + 0.002,
                "{}: note at {} µs sounded {error} ms off ({queued} writes queued)",
                path.display(),
                note.score_us
            );
        }
    }
}

#[test]
fn default_mechanics_with_compensation_sound_within_1ms_unless_the_guard_delays_them() {
    let robot = Robot::thesis();
    for (path, _) in well_formed() {
        let song = load_song(&path).unwrap();
        let out = render(&song, &robot, options(true)).unwrap();
        let late: Vec<_> = onset_errors(&out)
            .into_iter()
            .filter(|(n, e)| !n.delayed && e.abs() > 1.0)
            .collect();
        assert!(
            late.is_empty(),
            "{}: {} notes off by more than 1 ms, first {:?}",
            path.display(),
            late.len(),
            late.first()
        );
    }
}

/// Plays a byte stream through the engine, fed chunk by chunk.
fn replay(robot: &Robot, stream: &[(u64, u8)], cuts: &[usize]) -> orch_sim::Performance {
    let mut engine = Engine::new(robot).unwrap();
    let mut from = 0;
    for &to in cuts.iter().chain(std::iter::once(&stream.len())) {
        for &(t, b) in &stream[from..to] {
            engine.push(t, b).unwrap();
        }
        from = to;
    }
    let last = stream.last().map_or(0, |s| s.0);
    let end = engine.drain(last + 1).unwrap();
    engine.finish(end + 100_000).0
}

#[test]
fn a_byte_stream_split_into_random_chunks_gives_the_identical_performance() {
    let robot = Robot::thesis();
    let path = corpus_dir().join("bach-invention-01.mid");
    let song = load_song(&path).unwrap();
    let sched = plan(&song, &robot, options(true));
    let stream: Vec<(u64, u8)> = sends(&sched, 1000)
        .iter()
        .flat_map(|s| s.bytes.iter().map(move |&b| (s.t_us, b)))
        .collect();
    let whole = replay(&robot, &stream, &[]);
    assert!(whole.clean_onsets().count() > 400);
    // A small deterministic generator: the cuts differ from run to run of the loop.
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    for _ in 0..8 {
        let mut cuts = Vec::new();
        let mut at = 0usize;
        loop {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            at += 1 + (seed % 97) as usize;
            if at >= stream.len() {
                break;
            }
            cuts.push(at);
        }
        assert_eq!(replay(&robot, &stream, &cuts), whole);
    }
}

#[test]
fn compensation_brings_onsets_closer_to_the_score() {
    let robot = Robot::thesis();
    let song = load_song(&corpus_dir().join("joplin-maple-leaf-rag.mid")).unwrap();
    let on = render(&song, &robot, options(true)).unwrap();
    let off = render(&song, &robot, options(false)).unwrap();
    let report = Report::new(song.notes() as u64, &on, &off);
    assert!(report.onset_ms.median < 1.0, "{report:?}");
    assert!(report.onset_uncompensated_ms.median >= 15.0, "{report:?}");
}
