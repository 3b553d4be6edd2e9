//! The invariants the `smf` fuzz target checks, shared with the stable-Rust test
//! `crates/seq/tests/fuzz_replay.rs`, which replays the corpus and the regressions with it.
//! Both use it from here (testkit's `fuzz-smf` feature).
//!
//! An input is the bytes of a would-be Standard MIDI File, as is: the seeds are real files
//! and cut or damaged copies. The schedule's settings (delays, re-strike gap, minimum press,
//! tempo scale, key map) come from a hash of the whole input, so every file is scheduled
//! under some setting and the fuzzer reaches them all by changing any byte.
//!
//! What must hold, for any input (a violation panics):
//!
//! - `Song::parse` returns, `Ok` or `Err`, and never panics;
//! - on `Ok`: events are in playing order (time and tick never go back), each event's time
//!   is the time of its tick, no event lies past `duration_ticks` / `duration_us`;
//!   `notes()` is the number of Note-Ons (0x9n) with velocity above 0; every event is a
//!   whole message, status byte first (channel messages of their proper length with data
//!   bytes below 0x80, SysEx `F0 … F7`); the tempo map starts at tick 0 and moves forward;
//! - the performer's streaming planner (`orch_perform::Planner`), with uniform leads, a
//!   re-strike gap, a minimum press, a late limit, either overlap and a tempo factor from the
//!   hash, sends exactly what planning the whole song first sends; every score message goes
//!   out exactly once (a Note-On the planner drops is accounted as dropped), with its own
//!   bytes; sends are in time order and never before the start; one key's score messages keep
//!   their score order; what the planner adds are Note-Offs; with compensation off every
//!   message goes at its score time, in the song's order.

use orch_core::{ChannelMask, KeyRange, Note, OutOfRange, Overlap};
use orch_perform::{KeyMap, PlanRules, Planned, Planner, ScoreEvent, Tempo};
use orch_seq::{Event, Song};

/// Checks every invariant on one input. Panics on a violation.
pub fn check(data: &[u8]) {
    let Ok(song) = Song::parse(data) else {
        return;
    };
    check_song(&song);
    let settings = Settings::from_input(data);
    check_plan(&song, &settings);
}

// ---------------------------------------------------------------------------------------------
// The song

fn check_song(song: &Song) {
    let events = song.events();
    for pair in events.windows(2) {
        assert!(
            pair[0].time_us <= pair[1].time_us,
            "events out of time order: {:?} then {:?}",
            pair[0],
            pair[1]
        );
        assert!(
            pair[0].tick <= pair[1].tick,
            "events out of tick order: {:?} then {:?}",
            pair[0],
            pair[1]
        );
    }
    for e in events {
        assert_eq!(
            e.time_us,
            song.time_at_tick(e.tick),
            "event time is not its tick's time: {e:?}"
        );
        assert!(
            e.tick <= song.duration_ticks(),
            "event past duration_ticks {}: {e:?}",
            song.duration_ticks()
        );
        assert!(
            e.time_us <= song.duration_us(),
            "event past duration_us {}: {e:?}",
            song.duration_us()
        );
        check_message(e);
    }

    let note_ons = events
        .iter()
        .filter(|e| e.bytes.len() == 3 && e.bytes[0] & 0xF0 == 0x90 && e.bytes[2] > 0)
        .count();
    assert_eq!(
        song.notes(),
        note_ons,
        "notes() is not the count of Note-Ons"
    );

    let map = song.tempo_map();
    assert!(
        map.first().is_some_and(|c| c.tick == 0 && c.time_us == 0),
        "tempo map does not start at 0: {map:?}"
    );
    for pair in map.windows(2) {
        assert!(
            pair[0].tick < pair[1].tick && pair[0].time_us <= pair[1].time_us,
            "tempo map goes back: {pair:?}"
        );
    }
}

/// A whole MIDI message, status first, as the song promises.
fn check_message(e: &Event) {
    let b = &e.bytes[..];
    let status = *b.first().unwrap_or_else(|| panic!("empty message: {e:?}"));
    match status {
        0x80..=0xEF => {
            let len = if matches!(status & 0xF0, 0xC0 | 0xD0) {
                2
            } else {
                3
            };
            assert_eq!(b.len(), len, "channel message of the wrong length: {e:?}");
            assert!(
                b[1..].iter().all(|&d| d < 0x80),
                "status byte inside a channel message: {e:?}"
            );
        }
        0xF0 => {
            assert!(
                b.len() >= 2 && b[b.len() - 1] == 0xF7,
                "SysEx not closed by F7: {e:?}"
            );
        }
        _ => panic!("the song emitted a message starting {status:#04X}: {e:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// The plan

/// The planner's settings, from a hash of the input.
struct Settings {
    press_us: u64,
    release_us: u64,
    gap_us: u64,
    min_press_us: u64,
    late_limit_us: Option<u64>,
    overlap: Overlap,
    tempo: Tempo,
    /// Fold notes into the 61 keys 36..=96 (several notes share a key), else drop the others.
    fold: bool,
    /// Channels mapped: bit c for channel c.
    channels: u16,
}

impl Settings {
    fn from_input(data: &[u8]) -> Self {
        // FNV-1a, then a 64-bit mix: any byte changes every setting.
        let mut h: u64 = 0xCBF2_9CE4_8422_2325;
        for &b in data {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3);
        }
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        let tempos = [1.0, 1.0, 2.0, 0.5, 0.37, 3.0, 0.05, 20.0];
        Self {
            press_us: (h & 0xFF) * 250,          // 0 to 64 ms
            release_us: ((h >> 8) & 0xFF) * 250, // 0 to 64 ms
            gap_us: ((h >> 16) & 0xFF) * 500,    // 0 to 128 ms
            min_press_us: ((h >> 24) & 0x3F) * 1_000,
            tempo: Tempo::new(tempos[((h >> 30) & 7) as usize]).expect("finite, above 0"),
            fold: (h >> 33) & 1 == 1,
            channels: if (h >> 34) & 1 == 1 {
                0xFFFF
            } else {
                (h >> 35) as u16
            },
            late_limit_us: ((h >> 51) & 1 == 1).then_some(((h >> 52) & 0x3F) * 1_000),
            overlap: if (h >> 58) & 1 == 1 {
                Overlap::Hold
            } else {
                Overlap::Restrike
            },
        }
    }

    fn rules(&self, compensation: bool) -> PlanRules {
        PlanRules {
            keys: KeyMap::new(orch_core::Config {
                channels: ChannelMask(self.channels),
                range: KeyRange::new(Note::from_bits(36), Note::from_bits(96)).expect("36..=96"),
                out_of_range: if self.fold {
                    OutOfRange::Fold
                } else {
                    OutOfRange::Drop
                },
                ..orch_perform::thesis_config()
            }),
            press_lead_us: vec![self.press_us; 61],
            press_lead_by_velocity_us: Vec::new(),
            release_lead_us: vec![self.release_us; 61],
            min_hold_us: vec![self.min_press_us / 2; 61],
            restrike_gap_us: self.gap_us,
            min_press_us: self.min_press_us,
            late_limit_us: self.late_limit_us,
            overlap: self.overlap,
            compensation,
            bus_margin_us: 0,
            extra_lookahead_us: 0,
        }
    }
}

fn score(events: &[Event]) -> impl Iterator<Item = ScoreEvent> + '_ {
    events.iter().map(|e| ScoreEvent {
        score_us: e.time_us,
        bytes: e.bytes.clone(),
    })
}

fn check_plan(song: &Song, s: &Settings) {
    let events = song.events();
    const START: i64 = 1_000;

    // No compensation: everything at its score time, in the song's order.
    let mut plain = Planner::new(score(events), s.rules(false), START, s.tempo);
    let mut n = 0;
    while let Some(p) = plain.next_planned() {
        let Planned::Send { at_us, bytes, .. } = p else {
            panic!("without compensation the planner dropped a note");
        };
        let e = &events[n];
        assert_eq!(bytes, e.bytes, "message {n} reordered without compensation");
        assert_eq!(
            at_us,
            plain.wall(e.time_us),
            "message {n} moved without compensation"
        );
        n += 1;
    }
    assert_eq!(n, events.len(), "the plain plan lost or added messages");

    // With compensation: streaming equals planning the whole song first.
    let mut streaming = Planner::new(score(events), s.rules(true), START, s.tempo);
    let mut whole = Planner::new(score(events), s.rules(true), START, s.tempo).eager();
    let mut plan = Vec::new();
    loop {
        let (a, b) = (streaming.next_planned(), whole.next_planned());
        assert_eq!(
            a,
            b,
            "streaming and whole-song plans differ at send {}",
            plan.len()
        );
        match a {
            Some(p) => plan.push(p),
            None => break,
        }
    }

    // Every score message once: the plan's own messages, in each key's score order.
    let keys = s.rules(true).keys;
    let mut expected: std::collections::VecDeque<&Event> = Default::default();
    let mut per_key: Vec<std::collections::VecDeque<&Event>> = vec![Default::default(); 61];
    let key_of = |e: &Event| {
        let (ch, n) = e
            .bytes
            .note_on()
            .map(|(c, n, _)| (c, n))
            .or(e.bytes.note_off())?;
        keys.land(ch, n).map(|l| usize::from(l.key))
    };
    for e in events {
        match key_of(e) {
            Some(k) => per_key[k].push_back(e),
            None => expected.push_back(e),
        }
    }
    let mut last_at = i64::MIN;
    let mut notes_seen = 0usize;
    for p in &plan {
        match p {
            Planned::Send {
                at_us,
                bytes,
                added,
                ..
            } => {
                assert!(*at_us >= last_at, "sends out of time order at {at_us} µs");
                assert!(*at_us >= 0, "a send before the start: {at_us} µs");
                last_at = *at_us;
                if *added {
                    assert!(bytes.note_off().is_some(), "the planner added {bytes:?}");
                    continue;
                }
                if bytes.note_on().is_some() {
                    notes_seen += 1;
                }
                let e = Event {
                    time_us: 0,
                    tick: 0,
                    track: 0,
                    bytes: bytes.clone(),
                };
                match key_of(&e) {
                    Some(k) => {
                        let next = per_key[k]
                            .pop_front()
                            .unwrap_or_else(|| panic!("key {k}: a message the score lacks"));
                        assert_eq!(&next.bytes, bytes, "key {k}: out of score order");
                    }
                    None => {
                        // Unkeyed messages keep their bytes; their order among keyed ones may
                        // differ, so find and take this one.
                        let i = expected
                            .iter()
                            .position(|x| &x.bytes == bytes)
                            .unwrap_or_else(|| panic!("a message the score lacks: {bytes:?}"));
                        expected.remove(i);
                    }
                }
            }
            Planned::Dropped {
                channel,
                note_number,
                ..
            } => {
                notes_seen += 1;
                let k = keys
                    .land(*channel, *note_number)
                    .map(|l| usize::from(l.key))
                    .expect("a dropped note has a key");
                let next = per_key[k]
                    .pop_front()
                    .expect("the dropped note is the score's");
                assert_eq!(next.bytes.note_on().map(|(_, n, _)| n), Some(*note_number));
            }
        }
    }
    assert!(
        expected.is_empty(),
        "{} unkeyed messages never sent",
        expected.len()
    );
    assert!(
        per_key.iter().all(|q| q.is_empty()),
        "keyed messages never sent"
    );
    assert_eq!(notes_seen, song.notes(), "notes lost or added");
}
