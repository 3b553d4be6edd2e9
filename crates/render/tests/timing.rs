//! The render against the virtual robot: each strike found in the audio on the sample the
//! virtual robot says it sounded (within 1), a dropped note silent where it would have been.
//! The strikes are found by `orch_render::onset` in the samples, and the robot's times are
//! read from its note-by-note account, not from the renderer.

mod support;

use orch_perform::{song_events, Performer, Played, Setup};
use orch_render::{events, onset, synth, Settings};
use orch_seq::Song;

const RATE: u32 = 44_100;

/// A format-0 file, 480 ticks a quarter at 120 bpm (1 ms = 0.96 tick): `(ms, note, velocity,
/// length ms)`, in time order.
fn smf(notes: &[(u32, u8, u8, u32)]) -> Song {
    let mut ev: Vec<(u32, Vec<u8>)> = Vec::new();
    for &(at, n, v, len) in notes {
        ev.push((at, vec![0x90, n, v]));
        ev.push((at + len, vec![0x80, n, 0]));
    }
    ev.sort_by_key(|e| e.0);
    let at: Vec<(u64, Vec<u8>)> = ev
        .into_iter()
        .map(|(ms, bytes)| (u64::from(ms) * 96 / 100, bytes))
        .collect();
    Song::parse(&testkit::smf::at_ticks(&at)).unwrap()
}

fn play(song: &Song, config: orch_core::Config<{ orch_perform::MAX_BOARDS }>) -> Played {
    let setup = Setup::new(
        config,
        orch_sim::SimConfig {
            keep: orch_sim::Keep::Everything,
            ..orch_sim::SimConfig::thesis()
        },
    );
    Performer::new(&setup, song_events(song), song.notes())
        .run()
        .unwrap()
}

/// The render of `played` with the test font, both channels.
fn render(played: &Played) -> (Vec<f32>, Vec<f32>) {
    render_with(played, support::square_font(RATE))
}

fn render_with(
    played: &Played,
    font: std::sync::Arc<orch_render::SoundFont>,
) -> (Vec<f32>, Vec<f32>) {
    let keys = events::from_performance(&played.performance, played.start_us, 36).unwrap();
    render_keys(&font, &keys)
}

/// `keys` rendered with `font` at the default settings, both channels.
fn render_keys(
    font: &std::sync::Arc<orch_render::SoundFont>,
    keys: &[events::KeyEvent],
) -> (Vec<f32>, Vec<f32>) {
    let (mut l, mut r) = (Vec::new(), Vec::new());
    synth::render(font, keys, &Settings::default(), |a, b| {
        l.extend_from_slice(a);
        r.extend_from_slice(b);
        Ok(())
    })
    .unwrap();
    (l, r)
}

/// The sample each sounded note's strike should begin on, by the account, in score order.
fn sounded_samples(played: &Played) -> Vec<i64> {
    played
        .account(|_, _| (1, 1))
        .iter()
        .filter_map(|n| n.sounded_ms)
        .map(|ms| (ms * f64::from(RATE) / 1000.0).round() as i64)
        .collect()
}

#[test]
fn every_strike_lands_within_one_sample_of_the_virtual_robots_time() {
    strikes_land_on_the_robots_samples(support::square_font(RATE));
}

#[test]
fn a_soundfonts_envelope_delay_is_taken_off_each_strikes_start() {
    // rustysynth plays the SF2 default delay (1 ms) literally: 41 samples of silence at the
    // head of every voice, which the renderer measures and starts each voice early by.
    strikes_land_on_the_robots_samples(support::square_font_with_default_envelope(RATE));
}

fn strikes_land_on_the_robots_samples(font: std::sync::Arc<orch_render::SoundFont>) {
    // Single notes with silence between, across the keys, at times that fall on many a
    // sample position of the synthesizers' blocks (32 of the 64 at 44.1 kHz: each its own).
    let notes: Vec<(u32, u8, u8, u32)> = (0..32u32)
        .map(|i| {
            (
                300 + i * 700 + (i * 7) % 61,
                36 + (i as u8 * 5) % 61,
                100,
                120,
            )
        })
        .collect();
    let song = smf(&notes);
    let played = play(&song, orch_perform::thesis_config());
    let want = sounded_samples(&played);
    assert_eq!(want.len(), notes.len(), "every note sounds on the robot");
    let (l, r) = render_with(&played, font);
    let found = onset::onsets(&l, &r, 0.0, RATE as usize / 20);
    assert_eq!(found.len(), want.len(), "one onset a strike: {found:?}");
    let mut phases = [false; synth::PHASES];
    for (f, w) in found.iter().zip(&want) {
        assert!(
            (*f as i64 - w).abs() <= 1,
            "onset at sample {f}, the robot's strike at {w}"
        );
        phases[(*w as usize) % synth::PHASES] = true;
    }
    assert!(
        phases.iter().filter(|p| **p).count() >= 24,
        "the strikes fall on 24 positions in a block or more: {phases:?}"
    );
}

#[test]
fn a_dropped_note_is_silent_where_it_would_have_been() {
    // Note 20 is below the thesis's keys: dropped, not folded.
    let song = smf(&[
        (500, 60, 100, 200),
        (2000, 20, 100, 200),
        (3500, 72, 100, 200),
    ]);
    let mut config = orch_perform::thesis_config();
    config.out_of_range = orch_core::OutOfRange::Drop;
    let played = play(&song, config);
    let report = played.report(None);
    assert_eq!(report.outcomes.dropped.range, 1);
    let (l, r) = render(&played);
    let found = onset::onsets(&l, &r, 0.0, RATE as usize / 20);
    assert_eq!(found.len(), 2, "{found:?}");
    let at = |ms: usize| ms * RATE as usize / 1000;
    assert_eq!(
        onset::rms(&l, &r, at(1900), at(2600)),
        0.0,
        "silence at 2 s"
    );
    assert!(onset::rms(&l, &r, at(500), at(700)) > 0.01);
    assert!(onset::rms(&l, &r, at(3500), at(3700)) > 0.01);
}

#[test]
fn each_sound_ends_at_its_keys_return() {
    // Notes of different lengths; the test font sustains until released and dies away within
    // about a millisecond after (the SF2 default release).
    let notes: Vec<(u32, u8, u8, u32)> = (0..8u32)
        .map(|i| {
            (
                300 + i * 900 + (i * 7) % 61,
                40 + i as u8 * 6,
                100,
                60 + 70 * i,
            )
        })
        .collect();
    let song = smf(&notes);
    let played = play(&song, orch_perform::thesis_config());
    // The virtual robot's key-ups, in the song's samples.
    let ups: Vec<i64> = played
        .performance
        .sounds
        .iter()
        .filter(|s| s.kind == orch_sim::SoundKind::Up)
        .map(|s| {
            let ns = s.time.as_nanos() as i64 - played.start_us as i64 * 1000;
            (ns as f64 * f64::from(RATE) / 1e9).round() as i64
        })
        .collect();
    assert_eq!(ups.len(), notes.len());
    let (l, r) = render(&played);
    let found = onset::onsets(&l, &r, 0.0, RATE as usize / 20);
    assert_eq!(found.len(), notes.len());
    for (i, up) in ups.iter().enumerate() {
        let until = found.get(i + 1).copied().unwrap_or(l.len());
        let last = (found[i]..until)
            .rev()
            .find(|&k| l[k] != 0.0 || r[k] != 0.0)
            .unwrap() as i64;
        // Sounding fully until the key is up; then released at the block after the key-up
        // (up to 63 samples) and gone 60 dB down within rustysynth's shortest release (it
        // clamps a release to 10 ms at least: 7.5 ms, 331 samples, to −60 dB), plus a block
        // for the envelope to be seen below that.
        let before = onset::rms(&l, &r, *up as usize - 100, *up as usize);
        assert!(before > 0.01, "note {i}: RMS {before} before its key-up");
        assert!(
            last >= *up && last <= up + 63 + 331 + 64,
            "note {i}: the sound ends at sample {last}, the key is up at {up}"
        );
    }
}

#[test]
fn a_late_restrike_sounds_late_by_the_accounts_lateness() {
    // A short note, then the same key again 60 ms later: the key needs its rest (the guard's
    // re-strike gap) before it can strike again, so the second note is late.
    let song = smf(&[
        (500, 60, 100, 30),
        (560, 60, 100, 100),
        (1500, 64, 100, 100),
    ]);
    let played = play(&song, orch_perform::thesis_config());
    let lines = played.account(|_, _| (1, 1));
    assert_eq!(
        lines.iter().map(|l| l.outcome).collect::<Vec<_>>(),
        ["on_time", "late", "on_time"]
    );
    let late = &lines[1];
    let (l, r) = render(&played);
    // 10 ms of digital silence between the two strikes of the key.
    let found = onset::onsets(&l, &r, 0.0, RATE as usize / 100);
    assert_eq!(found.len(), 3, "{found:?}");
    let at = |ms: f64| (ms * f64::from(RATE) / 1000.0).round() as i64;
    let heard = found[1] as i64;
    assert!((heard - at(late.sounded_ms.unwrap())).abs() <= 1);
    let by = late.onset_ms.unwrap();
    assert!(by > 1.0, "late by {by} ms");
    assert!(
        ((heard - at(late.t_ms)) - at(by)).abs() <= 1,
        "heard {} samples after its score time, late by {by} ms",
        heard - at(late.t_ms)
    );
}

#[test]
fn a_strikes_level_follows_its_exact_loudness_between_whole_steps() {
    // A key whose softest duty is 1000 of 4095: a 4095th more duty is 0.04 of a velocity step
    // louder. Strikes 1 s apart, each held 0.5 s, at duties 3 of 4095 apart (0.12 step).
    let key = orch_sim::KeyMechanics {
        softest: 1000,
        ..orch_sim::KeyMechanics::DEFAULT
    };
    let duties: Vec<u16> = (0..40).map(|i| 1300 + 3 * i).collect();
    let mut keys = Vec::new();
    for (i, &d) in duties.iter().enumerate() {
        let at_ns = 1_000_000_000 * i as i64 + 100_000_000;
        let loudness = key.loudness_at(d).unwrap();
        keys.push(events::KeyEvent {
            at_ns,
            note: 60,
            instrument: events::Instrument::PIANO,
            action: events::Action::Strike { loudness },
        });
        keys.push(events::KeyEvent {
            at_ns: at_ns + 500_000_000,
            note: 60,
            instrument: events::Instrument::PIANO,
            action: events::Action::Release,
        });
    }
    let (l, r) = render_keys(&support::square_font(RATE), &keys);
    // Each strike's level in the audio, against its exact loudness's: the same offset for
    // every strike, within 0.08 dB (the channels' expression ladder: each within 0.04 dB; at
    // whole velocity steps, a step here is 0.65 dB).
    let offsets: Vec<f64> = keys
        .iter()
        .filter_map(|k| match k.action {
            events::Action::Strike { loudness } => Some((k.sample(RATE) as usize, loudness)),
            events::Action::Release => None,
        })
        .map(|(at, loudness)| {
            let heard = 20.0 * f64::from(onset::rms(&l, &r, at + 1000, at + 11_000)).log10();
            let want = 40.0 * (synth::synth_velocity(loudness.get()) / 127.0).log10();
            heard - want
        })
        .collect();
    let spread = offsets.iter().copied().fold(f64::MIN, f64::max)
        - offsets.iter().copied().fold(f64::MAX, f64::min);
    assert!(spread < 0.08, "levels off their loudness by {offsets:?}");
}

#[test]
fn a_ringing_output_sounds_past_its_key_up_until_it_strikes_again_or_for_eight_seconds() {
    // One key struck at 0.3 s and 1.5 s, each held 0.1 s; the test font sustains until
    // released. As a keyboard key it is silent between; as a bar it rings on.
    let song = smf(&[(300, 60, 100, 100), (1500, 60, 100, 100)]);
    let played = play(&song, orch_perform::thesis_config());
    let keys = 61;
    let render_as = |outputs: &[events::Output]| {
        let keys = events::from_robot(&played.performance, played.start_us, outputs, &[]).unwrap();
        render_keys(&support::square_font(RATE), &keys)
    };
    let at = |ms: usize| ms * RATE as usize / 1000;
    let (l, r) = render_as(&events::keyboard(36, keys));
    assert_eq!(onset::rms(&l, &r, at(800), at(1400)), 0.0, "a key: damped");
    let bars: Vec<events::Output> = (0..keys)
        .map(|k| events::Output::bar(events::Instrument::Program(9), 36 + k as u8))
        .collect();
    let (l, r) = render_as(&bars);
    let level = onset::rms(&l, &r, at(350), at(400));
    for ms in [800, 1400, 9000] {
        let now = onset::rms(&l, &r, at(ms), at(ms + 50));
        assert!(
            (now / level - 1.0).abs() < 0.01,
            "at {ms} ms: {now} against {level}"
        );
    }
    // Released 8 s after the last strike (9.5 s): gone within the font's release.
    let sounded = (0..l.len()).rev().find(|&k| l[k] != 0.0).unwrap();
    let ring_end = at(9500);
    assert!(
        sounded >= ring_end && sounded < ring_end + 64 + 331 + 64,
        "the ring ends at sample {sounded}, 8 s after the strike at {ring_end}"
    );
}

#[test]
fn a_beater_left_on_its_bar_chokes_it_where_the_virtual_robot_says() {
    // One key held 100 ms at 0.3 s, on a robot whose every output mutes after 20 ms on its
    // bar: the virtual robot says when it choked (its strike plus 20 ms), and as a bar the
    // render's sound ends there (within a block and the test font's release), not at the
    // next strike 8 s on.
    let song = smf(&[(300, 60, 100, 100)]);
    let mut sim = orch_sim::SimConfig {
        keep: orch_sim::Keep::Everything,
        ..orch_sim::SimConfig::thesis()
    };
    sim.mechanics.default.mute_after = Some(orch_core::Duration::from_millis(20));
    let setup = Setup::new(orch_perform::thesis_config(), sim);
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .run()
        .unwrap();
    let press = played.performance.presses[0];
    let (sounded, choked) = (press.sounded.unwrap(), press.muted.expect("muted"));
    assert_eq!(choked.nanos_since(sounded), 20_000_000);
    let bars: Vec<events::Output> = (0..61)
        .map(|k| events::Output::bar(events::Instrument::Program(9), 36 + k as u8))
        .collect();
    let keys = events::from_robot(&played.performance, played.start_us, &bars, &[]).unwrap();
    let (l, r) = render_keys(&support::square_font(RATE), &keys);
    let at = |ns: u64| ((ns - played.start_us * 1000) * u64::from(RATE) / 1_000_000_000) as usize;
    let last = (0..l.len())
        .rev()
        .find(|&k| l[k] != 0.0 || r[k] != 0.0)
        .unwrap();
    let choke = at(choked.as_nanos());
    assert!(
        last >= choke && last < choke + 64 + 331 + 64,
        "the bar sounds until sample {last}; choked at {choke}"
    );
}

#[test]
fn a_drums_release_does_not_touch_a_piano_key_of_the_same_note() {
    // The piano's 60 held from 0 to 2 s; the drum kit's 60 from sample 22 080 (the same
    // synthesizer: 345 blocks on) to 1 s. Both at full loudness, where the nearest channel
    // is the same: the drum takes another, and its release leaves the piano sounding.
    let strike = |at_ns: i64, instrument| events::KeyEvent {
        at_ns,
        note: 60,
        instrument,
        action: events::Action::Strike {
            loudness: orch_render::Loudness::of_velocity(127),
        },
    };
    let release = |at_ns: i64, instrument| events::KeyEvent {
        action: events::Action::Release,
        ..strike(at_ns, instrument)
    };
    let drum_at = (22_080.0 / f64::from(RATE) * 1e9).round() as i64;
    let keys = [
        strike(0, events::Instrument::PIANO),
        strike(drum_at, events::Instrument::Drums),
        release(1_000_000_000, events::Instrument::Drums),
        release(2_000_000_000, events::Instrument::PIANO),
    ];
    assert_eq!(keys[1].sample(RATE) % synth::PHASES as u64, 0);
    let (l, r) = render_keys(&support::square_font(RATE), &keys);
    let at = |ms: usize| ms * RATE as usize / 1000;
    let alone = onset::rms(&l, &r, at(100), at(400));
    let after = onset::rms(&l, &r, at(1200), at(1900));
    assert!(
        (after / alone - 1.0).abs() < 0.01,
        "the piano alone {alone}, after the drum's release {after}"
    );
}
