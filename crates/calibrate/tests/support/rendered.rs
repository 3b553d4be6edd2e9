//! Rendered recordings of the calibration score: the virtual robot with hidden per-key
//! mechanics plays the score (without latency compensation, as a real robot receives it),
//! `orch-render` makes it sound through the installed soundfont, and a room is added.
//!
//! - **The hidden robot** ([`hidden`]): the input robot file (the one the calibrator is
//!   given) with a `[[mechanics.key]]` entry for every key: a press delay at full power
//!   drawn from 5–40 ms, a soft press delay 5–25 ms more, a softest duty from
//!   `softest.0` to `softest.1` (its loudness curve: the virtual robot's loudness is
//!   `1 + 126 (d − softest) / (1 − softest)`). Its figures as loaded (the sim's own, rounded
//!   to µs and 4095ths) are the truth the calibration is compared with.
//! - **The sound** ([`record`]): the performance's strikes through `orch_render::synth`
//!   (TimGM6mb or whatever `orch render` would choose), the two channels mixed.
//!   Optionally one key's strikes are taken out: a key that never sounds.
//! - **A solenoid's thump** (optional, [`Room::thump`]): before each strike's string, the
//!   synthetic recordings' [`Solenoid`] thump, its level against the key's string at full
//!   power (the rendered string's RMS over its first 10 ms, less its strike's loudness in dB),
//!   times the strike's duty (from its loudness and the hidden key's softest); it goes
//!   through the room as the string does.
//! - **The room** ([`Room`]): the capture offset (whole samples of silence before the score's
//!   time 0); reverberation by convolution with a synthetic impulse response (the direct
//!   sound, then from 5 ms on exponentially decaying Gaussian noise with a 60 dB decay time
//!   of `rt60_s`, its energy `drr_db` below the direct sound's); white Gaussian noise at an
//!   SNR against the mean power of the (reverberant) performance from the first strike on.

#![allow(dead_code)] // each test file and example uses its own part

use std::sync::Arc;

use orch_calibrate::fit::db_of_loudness;
use orch_calibrate::synthetic::{HiddenKey, Rng, Solenoid};
use orch_calibrate::{Recording, Score};
use orch_perform::{song_events, MidiRecording, Outcome, Performer, Played, ScoreEvent, Setup};
use orch_render::{events, soundfont, synth, Action, KeyEvent, Settings, SoundFont};
use orch_robot::Robot;
use orch_seq::{Song, WireBytes};

/// The rate everything is rendered at.
pub const RATE: u32 = 44_100;

/// The soundfont `orch render` would choose (the test command installs TimGM6mb).
pub fn installed_font() -> Arc<SoundFont> {
    let path = soundfont::find(None).unwrap_or_else(|e| panic!("{e}"));
    soundfont::load(&path).unwrap()
}

/// A SoundFont 2 of one struck string, written here: see [`string_sample`]. Every key plays
/// it (root key 60, transposed by the synthesizer), its volume envelope without delay or
/// attack, released over 0.5 s (100 dB: a damper), not looped: a voice's sound starts at full level on its first sample, so the
/// strike's time is unambiguous (an installed font's piano samples have quiet pre-rolls and
/// attacks of up to 10 ms, which shift their audible onsets from the strike by the note:
/// README, "Calibrating by ear").
pub fn string_font() -> Arc<SoundFont> {
    sf2(&string_sample())
}

/// One struck string at middle C, 44.1 kHz, 4 s (so that at C7, played 8 times as fast, it
/// lasts 500 ms, past a strike's listening window: a sample ending sooner clicks there, a
/// second onset no string makes): 10 partials `h f0 √(1 + B h²)` (B =
/// 10⁻⁴), amplitudes `1/h`, random phases, each decaying with a time constant of `0.8 s /
/// (1 + 0.4 (h − 1))`; it starts at full level on its first sample (the hammer's contact),
/// peak 0.5 of full scale.
pub fn string_sample() -> Vec<i16> {
    let rate = f64::from(RATE);
    let f0 = 261.625_565;
    let mut rng = Rng::new(0x0571_2146);
    let partials: Vec<(f64, f64, f64, f64)> = (1..=10)
        .map(|h| {
            let h = f64::from(h);
            let f = h * f0 * (1.0 + 1e-4 * h * h).sqrt();
            let phase = rng.range(0.0, 2.0 * std::f64::consts::PI);
            (f, 1.0 / h, 0.8 / (1.0 + 0.4 * (h - 1.0)), phase)
        })
        .collect();
    let x: Vec<f64> = (0..(4.0 * rate) as usize)
        .map(|n| {
            let t = n as f64 / rate;
            partials
                .iter()
                .map(|&(f, a, tau, ph)| {
                    a * (-t / tau).exp() * (2.0 * std::f64::consts::PI * f * t + ph).sin()
                })
                .sum()
        })
        .collect();
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter()
        .map(|v| (v / peak * 0.5 * 32767.0).round() as i16)
        .collect()
}

/// A SoundFont 2 with one preset (bank 0, program 0) playing `wave` (44.1 kHz, root key 60)
/// on every key, once, with no envelope delay or attack.
fn sf2(wave: &[i16]) -> Arc<SoundFont> {
    use sf2::*;
    one_sample(
        wave,
        RATE,
        &[
            (DELAY_VOL_ENV, NO_TIME),
            (ATTACK_VOL_ENV, NO_TIME),
            // -1200 timecents, 0.5 s for 100 dB (a damper's 43 ms time constant).
            (RELEASE_VOL_ENV, -1200),
            (SAMPLE_MODES, 0), // not looped
        ],
    )
}

use testkit::sf2;

/// A robot with hidden per-key mechanics.
pub struct Hidden {
    /// Its robot.toml.
    pub text: String,
    /// It, loaded.
    pub robot: Robot,
    /// Each key's figures as the virtual robot has them, lowest first.
    pub keys: Vec<HiddenKey>,
}

/// The robot file `input` with random per-key mechanics (see the module notes).
pub fn hidden(input: &str, softest: (f64, f64), seed: u64) -> Hidden {
    let base = Robot::from_toml(input).unwrap();
    let (low, high) = (
        base.config.range.low().get(),
        base.config.range.high().get(),
    );
    let mut rng = Rng::new(seed);
    let mut text = input.to_string();
    for note in low..=high {
        let press = rng.range(5.0, 40.0);
        let soft = press + rng.range(5.0, 25.0);
        let s = rng.range(softest.0, softest.1);
        text += &format!(
            "\n[[mechanics.key]]\nnote = {note}\npress_delay = \"{:.0}us\"\n\
             soft_press_delay = \"{:.0}us\"\nsoftest = \"{:.3}%\"\n",
            press * 1000.0,
            soft * 1000.0,
            s * 100.0
        );
    }
    let robot = Robot::from_toml(&text).unwrap();
    let keys = (0..=high - low)
        .map(|k| {
            let m = robot.mechanics.for_key(k);
            HiddenKey {
                press_delay_ms: m.press_delay.as_micros() as f64 / 1000.0,
                soft_press_delay_ms: m.soft_press_delay.as_micros() as f64 / 1000.0,
                softest: f64::from(m.softest) / 4095.0,
                gain: 1.0,
                dead: false,
            }
        })
        .collect();
    Hidden { text, robot, keys }
}

/// How `robot` plays on the virtual clock, every sound kept.
pub fn setup(robot: &Robot, compensation: bool) -> Setup {
    Setup::for_robot(robot)
        .with_keep(orch_sim::Keep::Everything)
        .with_compensation(compensation)
}

/// Plays `song` as `setup` says, on the virtual clock.
pub fn play(song: &Song, setup: &Setup) -> Played {
    Performer::new(setup, song_events(song), song.notes())
        .run()
        .unwrap()
}

/// The room.
#[derive(Clone, Copy, Debug)]
pub struct Room {
    /// How long before the score's time 0 the recording starts, ms (rounded to a sample).
    pub capture_offset_ms: f64,
    /// Reverberation: (60 dB decay time s, direct-to-reverberant ratio dB).
    pub reverb: Option<(f64, f64)>,
    /// Signal-to-noise ratio, dB.
    pub snr_db: Option<f64>,
    /// A solenoid's thump before each string (`None`: none).
    pub thump: Option<Solenoid>,
    /// The noise's seed.
    pub seed: u64,
}

impl Room {
    /// The capture offset as recorded: whole samples, ms.
    pub fn offset_ms(&self) -> f64 {
        self.offset_samples() as f64 * 1000.0 / f64::from(RATE)
    }

    fn offset_samples(&self) -> usize {
        (self.capture_offset_ms * f64::from(RATE) / 1000.0).round() as usize
    }
}

/// The score played by the hidden robot (without compensation), rendered through `font`,
/// in `room`; `silent`: a key whose strikes make no sound.
pub fn record(
    score: &Score,
    hidden: &Hidden,
    font: &Arc<SoundFont>,
    room: &Room,
    silent: Option<u8>,
) -> Recording {
    let song = Song::parse(&score.to_smf()).unwrap();
    let played = play(&song, &setup(&hidden.robot, false));
    let low = hidden.robot.config.range.low().get();
    let mut keys = events::from_performance(&played.performance, played.start_us, low).unwrap();
    keys.retain(|k: &KeyEvent| Some(k.note) != silent || k.action == Action::Release);
    let mut x = vec![0.0f64; room.offset_samples()];
    synth::render(font, &keys, &Settings::default(), |l, r| {
        x.extend(l.iter().zip(r).map(|(a, b)| 0.5 * f64::from(a + b)));
        Ok(())
    })
    .unwrap();
    // Room for the score's last strike to ring, as a recording would have.
    let want =
        room.offset_samples() + (f64::from(score.length_ms()) / 1000.0 * f64::from(RATE)) as usize;
    if x.len() < want {
        x.resize(want, 0.0);
    }
    let mut rng = Rng::new(room.seed ^ 0x000A_0D10);
    if let Some(t) = room.thump {
        add_thumps(&mut x, &keys, hidden, room.offset_samples(), &t, &mut rng);
    }
    if let Some((rt60, drr)) = room.reverb {
        x = convolve(&x, &impulse_response(rt60, drr, &mut rng));
    }
    if let Some(snr) = room.snr_db {
        let from = room.offset_samples()
            + (f64::from(orch_calibrate::score::LEAD_IN_MS) / 1000.0 * f64::from(RATE)) as usize;
        let span = &x[from.min(x.len())..];
        let power = span.iter().map(|v| v * v).sum::<f64>() / span.len().max(1) as f64;
        let sigma = (power / 10f64.powf(snr / 10.0)).sqrt();
        for v in &mut x {
            *v += sigma * rng.normal();
        }
    }
    Recording::from_samples(RATE, x.into_iter().map(|v| v as f32).collect())
}

/// A thump before each of `keys`' strikes (their strings start at their sample, `offset`
/// samples into `x`): see the module notes.
fn add_thumps(
    x: &mut [f64],
    keys: &[KeyEvent],
    hidden: &Hidden,
    offset: usize,
    thump: &Solenoid,
    rng: &mut Rng,
) {
    let low = hidden.robot.config.range.low().get();
    let window = (0.010 * f64::from(RATE)) as usize;
    // Each strike's sample and thump amplitude, all measured before any thump is added.
    let strikes: Vec<(usize, f64)> = keys
        .iter()
        .filter_map(|k| {
            let Action::Strike { loudness } = k.action else {
                return None;
            };
            let at = offset + k.sample(RATE) as usize;
            let span = &x[at.min(x.len())..(at + window).min(x.len())];
            let rms = (span.iter().map(|v| v * v).sum::<f64>() / span.len().max(1) as f64).sqrt();
            let full = rms / 10f64.powf(db_of_loudness(loudness.get()) / 20.0);
            let softest = hidden.keys[usize::from(k.note - low)].softest;
            let duty = if softest >= 1.0 {
                1.0
            } else {
                softest + (loudness.get() - 1.0) / 126.0 * (1.0 - softest)
            };
            Some((at, full * 10f64.powf(thump.level_db / 20.0) * duty))
        })
        .collect();
    for (at, amp) in strikes {
        thump.add(x, f64::from(RATE), at as f64, amp, rng);
    }
}

/// The room's impulse response: 1 (the direct sound), then from 5 ms on Gaussian noise
/// decaying 60 dB in `rt60` s, its energy `drr` dB below the direct sound's; `1.5 rt60` long.
pub fn impulse_response(rt60: f64, drr: f64, rng: &mut Rng) -> Vec<f64> {
    let rate = f64::from(RATE);
    let len = (1.5 * rt60 * rate) as usize;
    let first = (0.005 * rate) as usize;
    let mut h = vec![0.0; len];
    h[0] = 1.0;
    for (n, v) in h.iter_mut().enumerate().skip(first) {
        let t = n as f64 / rate;
        *v = rng.normal() * 10f64.powf(-3.0 * t / rt60);
    }
    let energy: f64 = h[first..].iter().map(|v| v * v).sum();
    let g = (10f64.powf(-drr / 10.0) / energy).sqrt();
    for v in &mut h[first..] {
        *v *= g;
    }
    h
}

/// `x` convolved with `h` (overlap-add through a real FFT), `x.len()` samples.
pub fn convolve(x: &[f64], h: &[f64]) -> Vec<f64> {
    use realfft::RealFftPlanner;
    let n = (2 * h.len()).next_power_of_two();
    let block = n - h.len() + 1;
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut hbuf = vec![0.0; n];
    hbuf[..h.len()].copy_from_slice(h);
    let mut hs = fwd.make_output_vec();
    fwd.process(&mut hbuf, &mut hs).unwrap();
    let mut out = vec![0.0; x.len() + n];
    let mut buf = vec![0.0; n];
    let mut spec = fwd.make_output_vec();
    for start in (0..x.len()).step_by(block) {
        let end = (start + block).min(x.len());
        buf.fill(0.0);
        buf[..end - start].copy_from_slice(&x[start..end]);
        fwd.process(&mut buf, &mut spec).unwrap();
        for (s, g) in spec.iter_mut().zip(&hs) {
            *s *= g;
        }
        inv.process(&mut spec, &mut buf).unwrap();
        for (o, v) in out[start..start + n].iter_mut().zip(&buf) {
            *o += v / n as f64;
        }
    }
    out.truncate(x.len());
    out
}

/// The signed onset error of a note record, ms.
fn signed_ms(o: Outcome) -> Option<f64> {
    match o {
        Outcome::OnTime { error_us } => Some(error_us as f64 / 1000.0),
        Outcome::Late { by_us } => Some(by_us as f64 / 1000.0),
        Outcome::Early { by_us } => Some(-(by_us as f64) / 1000.0),
        _ => None,
    }
}

/// `song` played with the robot file `file` by a robot whose keys move as `mechanics` says:
/// the sends of a performance on `file` (its compensation, from its mechanics), as they
/// leave for the robot, are what the robot receives and plays as a score without
/// compensation (its interpreter set up by `file`: the velocity curves are the file's, the
/// keys' motion is `mechanics`'). Each note's onset error, ms, against its score time.
pub fn onset_errors(song: &Song, file: &Robot, mechanics: &orch_sim::MechanicsConfig) -> Vec<f64> {
    let believed = file;
    let actual = &Robot {
        mechanics: mechanics.clone(),
        ..file.clone()
    };
    let mut sends = MidiRecording::default();
    let planned = Performer::new(
        &setup(believed, true),
        orch_perform::song_events(song),
        song.notes(),
    )
    .midi(&mut sends)
    .run()
    .unwrap();
    // The sends, running status undone, from 1 s on (the first may precede the song).
    let t0 = sends.sent.first().map_or(0, |s| s.0);
    let mut status = 0u8;
    let mut events = Vec::new();
    let mut notes = 0;
    for (t, bytes) in &sends.sent {
        let mut m = bytes.clone();
        if m[0] < 0x80 {
            m.insert(0, status);
        } else if m[0] < 0xF0 {
            status = m[0];
        }
        let b = WireBytes::new(&m);
        notes += usize::from(b.note_on().is_some());
        events.push(ScoreEvent {
            score_us: t - t0 + 1_000_000,
            bytes: b,
        });
    }
    let played = Performer::new(&setup(actual, false), events.into_iter(), notes)
        .run()
        .unwrap();
    // Each note of the second performance is a send of the first: (its send time, note) finds
    // the score note it was.
    let score_of: std::collections::HashMap<(u64, u8), i64> = planned
        .records
        .iter()
        .filter_map(|r| Some(((r.sent_us()?, r.note), r.score_at_us)))
        .collect();
    played
        .records
        .iter()
        .filter_map(|r| {
            let sounded = r.score_at_us as f64 + signed_ms(r.outcome)? * 1000.0;
            let sent = (r.score_at_us - played.start_us as i64 - 1_000_000 + t0 as i64) as u64;
            let score = *score_of.get(&(sent, r.note))?;
            // On the first performance's clock.
            let sounded = sounded - played.start_us as f64 - 1e6 + t0 as f64;
            Some((sounded - score as f64) / 1000.0)
        })
        .collect()
}

/// The median of the magnitudes.
pub fn median_abs(x: &[f64]) -> f64 {
    let mut a: Vec<f64> = x.iter().map(|v| v.abs()).collect();
    a.sort_by(f64::total_cmp);
    a[a.len() / 2]
}
