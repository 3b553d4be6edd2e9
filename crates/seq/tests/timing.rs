//! Times from hand-built files: tempo changes, SMPTE division, formats 1 and 2, bars and beats.

mod common;

use common::{off, on, smf, tempo};
use orch_seq::{midly, Song};

fn times(song: &Song) -> Vec<(u64, Vec<u8>)> {
    song.events()
        .iter()
        .map(|e| (e.time_us, e.bytes.to_vec()))
        .collect()
}

#[test]
fn tempo_change_from_120_to_60_bpm_gives_exact_times() {
    let bytes = smf(
        0,
        480,
        &[vec![
            (0, tempo(500_000)),
            (0, on(0, 60)),
            (480, off(0, 60)),       // 0.5 s
            (480, tempo(1_000_000)), // tick 960 = 1 s, now 60 bpm
            (0, on(0, 62)),          // 1 s
            (240, off(0, 62)),       // 1.5 s
            (240, on(0, 64)),        // 2 s
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    let t: Vec<u64> = song.events().iter().map(|e| e.time_us).collect();
    assert_eq!(t, [0, 500_000, 1_000_000, 1_500_000, 2_000_000]);
    let map = song.tempo_map();
    assert_eq!(map.len(), 2);
    assert_eq!(
        (map[1].tick, map[1].time_us, map[1].us_per_quarter),
        (960, 1_000_000, 1_000_000)
    );
    assert_eq!(song.tempo_at(1_200_000).bpm(), 60.0);
    assert_eq!(song.tempo_at(10).bpm(), 120.0);
}

#[test]
fn default_tempo_is_120_bpm_until_the_first_tempo_event() {
    let bytes = smf(
        0,
        96,
        &[vec![
            (96, on(0, 60)),
            (96, tempo(250_000)),
            (96, off(0, 60)),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    let t: Vec<u64> = song.events().iter().map(|e| e.time_us).collect();
    assert_eq!(t, [500_000, 1_250_000]);
}

#[test]
fn times_do_not_drift_across_many_tempo_events() {
    // 3 ticks per quarter at 1 s per quarter: a tick is 1/3 s. Re-stating the tempo every
    // tick 3000 times must still land exactly on whole seconds every 3 ticks.
    let mut track = vec![(0, tempo(1_000_000))];
    for _ in 0..3000 {
        track.push((1, tempo(1_000_000)));
    }
    track.push((0, on(0, 60)));
    let song = Song::parse(&smf(0, 3, &[track])).unwrap();
    assert_eq!(song.events()[0].time_us, 1_000_000_000);
    assert_eq!(song.time_at_tick(1), 333_333);
    assert_eq!(song.time_at_tick(2), 666_666);
    assert_eq!(song.time_at_tick(3), 1_000_000);
}

#[test]
fn smpte_25_fps_by_40_ticks_is_one_ms_per_tick_and_ignores_tempo() {
    let division = 0xE728; // −25 fps, 40 ticks per frame
    let bytes = smf(
        0,
        division,
        &[vec![
            (0, tempo(1_000_000)),
            (1000, on(0, 60)),
            (1, off(0, 60)),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(times(&song)[0].0, 1_000_000);
    assert_eq!(times(&song)[1].0, 1_001_000);
    assert!(matches!(
        song.timing(),
        midly::Timing::Timecode(midly::Fps::Fps25, 40)
    ));
    assert_eq!(song.ticks_per_quarter(), None);
}

#[test]
fn smpte_29_97_drop_frame_counts_30000_over_1001_fps() {
    let division = u16::from_be_bytes([(-29i8) as u8, 80]);
    let bytes = smf(0, division, &[vec![(2400, on(0, 60))]]);
    let song = Song::parse(&bytes).unwrap();
    // 2400 ticks = 30 frames = 30 × 1001 / 30000 s.
    assert_eq!(song.events()[0].time_us, 1_001_000);
}

#[test]
fn format_1_tempo_track_applies_to_the_other_tracks() {
    let bytes = smf(
        1,
        480,
        &[
            vec![(0, tempo(1_000_000)), (960, tempo(500_000))],
            vec![(480, on(1, 60)), (960, off(1, 60))],
        ],
    );
    let song = Song::parse(&bytes).unwrap();
    let t: Vec<u64> = song.events().iter().map(|e| e.time_us).collect();
    assert_eq!(t, [1_000_000, 2_500_000]);
    assert!(song.events().iter().all(|e| e.track == 1));
}

#[test]
fn format_1_tempo_event_in_a_later_track_applies_to_earlier_tracks() {
    let bytes = smf(
        1,
        480,
        &[vec![(960, on(0, 60))], vec![(0, tempo(1_000_000))]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(song.events()[0].time_us, 2_000_000);
}

#[test]
fn format_2_plays_tracks_one_after_another_each_with_its_own_tempo() {
    let bytes = smf(
        2,
        480,
        &[
            vec![(0, on(0, 60)), (480, off(0, 60))],
            vec![(0, tempo(1_000_000)), (0, on(0, 62)), (480, off(0, 62))],
            vec![(0, on(0, 64)), (480, off(0, 64))],
        ],
    );
    let song = Song::parse(&bytes).unwrap();
    let got: Vec<(u64, u64, u16)> = song
        .events()
        .iter()
        .map(|e| (e.tick, e.time_us, e.track))
        .collect();
    assert_eq!(
        got,
        [
            (0, 0, 0),
            (480, 500_000, 0),
            (480, 500_000, 1),
            (960, 1_500_000, 1),
            (960, 1_500_000, 2), // the third track is back at 120 bpm
            (1440, 2_000_000, 2),
        ]
    );
    assert_eq!(song.duration_us(), 2_000_000);
    assert_eq!(song.format(), midly::Format::Sequential);
}

#[test]
fn duration_runs_to_the_last_event_including_end_of_track() {
    let bytes = smf(
        0,
        480,
        &[vec![
            (0, on(0, 60)),
            (480, off(0, 60)),
            (960, vec![0xFF, 0x01, 0x01, b'x']),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(song.duration_us(), 1_500_000);
    assert_eq!(song.duration_ticks(), 1440);
}

#[test]
fn bar_and_beat_follow_time_signatures() {
    // 3/4 from the start, 6/8 from bar 3 (tick 2 × 1440 = 2880), ppq 480, 120 bpm.
    let bytes = smf(
        1,
        480,
        &[vec![
            (0, vec![0xFF, 0x58, 0x04, 3, 2, 24, 8]),
            (0, vec![0xFF, 0x03, 0x05, b'T', b'e', b'm', b'p', b'o']),
            (2880, vec![0xFF, 0x58, 0x04, 6, 3, 24, 8]),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    let at = |tick: u64| song.bar_beat(song.time_at_tick(tick));
    assert_eq!(at(0), (1, 1));
    assert_eq!(at(480), (1, 2));
    assert_eq!(at(1439), (1, 3));
    assert_eq!(at(1440), (2, 1));
    assert_eq!(at(2880), (3, 1));
    assert_eq!(at(2880 + 240), (3, 2)); // eighth-note beats
    assert_eq!(at(2880 + 6 * 240), (4, 1));
    assert_eq!(song.time_signatures().len(), 2);
    assert_eq!(song.time_signatures()[1].denominator(), 8);
    assert_eq!(song.track_names(), [Some("Tempo".to_string())]);
}

#[test]
fn bar_start_inverts_bar_and_beat_across_signatures_and_tempos() {
    // 3/4 from the start, 6/8 from bar 3 (tick 2880), ppq 480; 120 bpm, then 60 from tick 960
    // (times are deltas).
    let bytes = smf(
        1,
        480,
        &[vec![
            (0, vec![0xFF, 0x58, 0x04, 3, 2, 24, 8]),
            (960, vec![0xFF, 0x51, 0x03, 0x0F, 0x42, 0x40]),
            (1920, vec![0xFF, 0x58, 0x04, 6, 3, 24, 8]),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    assert_eq!(song.bar_start_us(0), None);
    for (bar, tick) in [
        (1, 0),
        (2, 1440),
        (3, 2880),
        (4, 2880 + 1440),
        (9, 2880 + 6 * 1440),
    ] {
        let t = song.bar_start_us(bar).unwrap();
        assert_eq!(t, song.time_at_tick(tick), "bar {bar}");
        assert_eq!(song.bar_beat(t), (bar, 1), "bar {bar}");
    }
    // Half a quarter at 60 bpm after the tempo change at 1 s.
    assert_eq!(song.time_at_quarters(2.5), 1_500_000);
}

#[test]
fn bar_and_beat_default_to_4_4() {
    let song = Song::parse(&smf(0, 480, &[vec![(4 * 480 + 480, on(0, 60))]])).unwrap();
    assert_eq!(song.bar_beat(song.events()[0].time_us), (2, 2));
}

#[test]
fn bar_and_beat_work_with_smpte_division() {
    // 25 fps × 40: 1 ms per tick, 120 bpm: a quarter is 500 ticks.
    let song = Song::parse(&smf(0, 0xE728, &[vec![(2500, on(0, 60))]])).unwrap();
    assert_eq!(song.bar_beat(song.events()[0].time_us), (2, 2));
}

#[test]
fn tick_at_time_inverts_time_at_tick() {
    let bytes = smf(
        0,
        96,
        &[vec![
            (0, tempo(333_333)),
            (100, tempo(700_001)),
            (100, on(0, 1)),
        ]],
    );
    let song = Song::parse(&bytes).unwrap();
    for tick in 0..400 {
        let t = song.time_at_tick(tick);
        assert_eq!(song.time_at_tick(song.tick_at_time(t)), t);
        assert!(song.tick_at_time(t) >= tick);
    }
}
