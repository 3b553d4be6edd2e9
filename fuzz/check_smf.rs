//! The invariants the `smf` fuzz target checks, shared with the stable-Rust test
//! `crates/seq/tests/fuzz_replay.rs`, which replays the corpus and the regressions with it.
//! Plain Rust: depends on `orch_seq` and `std` only, so both can include it with `#[path]`.
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
//! - `schedule` without compensation sends every event at its (scaled) score time, in the
//!   song's order;
//! - `schedule` with `Compensation::uniform(..)` and a re-strike gap: every event is sent
//!   exactly once, sends are in time order, one key's messages keep their score order, a
//!   press after a release of its key comes at least the re-strike gap later, and sends
//!   never precede 0;
//! - playing the schedule on a `VirtualClock` sends every entry, on time, and its
//!   running-status wire bytes expand back to the same messages.

use orch_seq::{
    schedule, Clock, Compensation, Event, RunningStatus, Song, TempoScale, VirtualClock,
};

/// Checks every invariant on one input. Panics on a violation.
pub fn check(data: &[u8]) {
    let Ok(song) = Song::parse(data) else {
        return;
    };
    check_song(&song);
    let settings = Settings::from_input(data);
    check_schedule(&song, &settings);
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
// The schedule

/// The schedule's settings, from a hash of the input.
struct Settings {
    press_us: u64,
    release_us: u64,
    gap_us: u64,
    min_press_us: u64,
    scale: TempoScale,
    /// Fold notes into the 61 keys 36..=96 (several notes share a key), else one key a note.
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
        let scales = [1.0, 1.0, 2.0, 0.5, 0.37, 3.0, 1e-3, 1e6];
        Self {
            press_us: (h & 0xFF) * 250,          // 0 to 64 ms
            release_us: ((h >> 8) & 0xFF) * 250, // 0 to 64 ms
            gap_us: ((h >> 16) & 0xFF) * 500,    // 0 to 128 ms
            min_press_us: ((h >> 24) & 0x3F) * 1_000,
            scale: TempoScale::new(scales[((h >> 30) & 7) as usize]).expect("finite, above 0"),
            fold: (h >> 33) & 1 == 1,
            channels: if (h >> 34) & 1 == 1 {
                0xFFFF
            } else {
                (h >> 35) as u16
            },
        }
    }

    fn key_of(&self, channel: u8, note: u8) -> Option<u16> {
        if self.channels & (1 << (channel & 0x0F)) == 0 {
            return None;
        }
        if self.fold {
            let mut n = note;
            while n < 36 {
                n += 12;
            }
            while n > 96 {
                n -= 12;
            }
            Some(u16::from(n - 36))
        } else {
            Some(u16::from(note))
        }
    }
}

fn check_schedule(song: &Song, s: &Settings) {
    let events = song.events();

    // No compensation: everything at its score time, in the song's order.
    let plain = schedule(events, s.scale, None);
    assert_eq!(plain.entries().len(), events.len());
    assert_eq!(plain.lead_in_us(), 0);
    for (i, entry) in plain.entries().iter().enumerate() {
        assert_eq!(entry.event, i, "uncompensated schedule reordered the song");
        assert_eq!(entry.send_us, entry.score_us, "uncompensated send moved");
    }

    let comp = Compensation::uniform(|ch, note| s.key_of(ch, note), s.press_us, s.release_us)
        .restrike_gap_us(s.gap_us)
        .min_press_us(s.min_press_us);
    let plan = schedule(events, s.scale, Some(&comp));
    let entries = plan.entries();
    assert_eq!(
        entries.len(),
        events.len(),
        "the schedule lost or added events"
    );
    let mut seen = vec![false; events.len()];
    for e in entries {
        assert!(!seen[e.event], "event {} scheduled twice", e.event);
        seen[e.event] = true;
        assert_eq!(e.bytes, events[e.event].bytes, "entry carries other bytes");
    }
    for pair in entries.windows(2) {
        assert!(
            pair[0].send_us <= pair[1].send_us,
            "schedule not sorted by send time: {:?} then {:?}",
            pair[0],
            pair[1]
        );
    }

    // Per key: score order kept, and the re-strike gap after each release.
    let mut last: std::collections::BTreeMap<u16, (usize, bool, u64)> = Default::default();
    for e in entries {
        let Some(key) = e.key else { continue };
        let press = e.bytes.note_on().is_some();
        assert!(
            press || e.bytes.note_off().is_some(),
            "a keyed entry that is no note: {e:?}"
        );
        if let Some(&(prev_event, prev_press, prev_send)) = last.get(&key) {
            assert!(
                prev_event < e.event,
                "key {key}: event {} sent after event {prev_event}, against the score",
                e.event
            );
            if press && !prev_press {
                assert!(
                    e.send_us >= prev_send + s.gap_us,
                    "key {key}: press at {} µs only {} µs after its release (gap {} µs)",
                    e.send_us,
                    e.send_us - prev_send,
                    s.gap_us
                );
            }
        }
        last.insert(key, (e.event, press, e.send_us));
    }

    // Play it on the virtual clock: every entry goes, on time; the running-status bytes expand
    // back to the messages.
    let mut clock = VirtualClock::new();
    let mut sent: Vec<(u64, Vec<u8>)> = Vec::new();
    let lateness = plan.play(&mut clock, RunningStatus::On, |t, bytes| {
        sent.push((t, bytes.to_vec()));
    });
    assert_eq!(sent.len(), entries.len(), "play skipped entries");
    assert_eq!(lateness.max_us, 0, "the virtual clock was late");
    assert_eq!(
        clock.now_us(),
        entries.last().map_or(0, |e| e.send_us),
        "the virtual clock did not end at the last send"
    );
    let mut status: Option<u8> = None;
    for ((t, bytes), e) in sent.iter().zip(entries) {
        assert_eq!(*t, e.send_us, "sent at another time than scheduled");
        let whole: Vec<u8> = match bytes.first() {
            Some(&b) if b < 0x80 => {
                let s = status.unwrap_or_else(|| panic!("running status with none in force"));
                std::iter::once(s).chain(bytes.iter().copied()).collect()
            }
            _ => bytes.clone(),
        };
        match whole.first() {
            Some(&b @ 0x80..=0xEF) => status = Some(b),
            Some(0xF0..=0xF7) => status = None,
            _ => {}
        }
        assert_eq!(&whole[..], &e.bytes[..], "wire bytes do not expand back");
    }
}
