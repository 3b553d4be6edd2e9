//! Synthetic recordings of the calibration score, for tests and figures: a robot whose keys'
//! figures are known (hidden from the analysis), a simple struck string, a room.
//!
//! - **The keys** ([`HiddenKey`]): a press delay at full power and at the softest duty, a
//!   softest duty below which the key makes no sound, a gain (how loud the microphone hears
//!   it at full power). A strike at duty `d ≥ softest` sounds at the virtual robot's
//!   loudness `v = 1 + 126 (d − softest) / (1 − softest)`, at `gain` times the level the
//!   virtual robot sounds it at ([`db_of_loudness`](crate::fit::db_of_loudness): −36 dB at
//!   loudness 1), after the virtual robot's press
//!   delay (linear in the duty).
//! - **The string**: 10 partials `h f0 √(1 + B h²)` (B = 10⁻⁴), amplitudes `1/h`, random
//!   phases, each decaying with a time constant from 1.2 s (C2) to about 0.3 s (C7),
//!   shorter for higher partials; a 3 ms raised-cosine attack; the damper, 25 ms after the
//!   note's end, stops it with a 40 ms time constant.
//! - **A mechanical thump** before each string, optionally ([`Thump`]): the first model's
//!   click ([`Thump::Click`]: 4 ms of decaying white noise 12 ms before the string, as loud
//!   as the string, its amplitude), or a solenoid's ([`Thump::Solenoid`], [`Solenoid`]): a
//!   click and the case's low-frequency thud, 2–5 ms before the string, its level set by the
//!   solenoid's drive rather than by the string's loudness.
//! - **A strike robot's outputs** ([`kit`]): drums, each a noise burst and a damped tone.
//! - **The room** ([`Room`]): the capture offset (the recording starts that long before the
//!   score), an optional **reverberation** (four parallel feedback combs of 29.7, 37.1, 41.1
//!   and 43.7 ms with a 0.6 s reverberation time, mixed at 30 %: a decaying tail, and echoes
//!   that ripple the onsets), and white Gaussian **noise** at an SNR against the mean power
//!   of the (reverberant) performance from its first strike to its last sound.

use crate::score::{Score, NOTE_MS};
use crate::wav::Recording;

pub mod kit;

/// One key of the hidden robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HiddenKey {
    /// Press delay at full power, ms.
    pub press_delay_ms: f64,
    /// Press delay at `softest`, ms.
    pub soft_press_delay_ms: f64,
    /// The softest duty that sounds, 0..=1.
    pub softest: f64,
    /// Amplitude at full power.
    pub gain: f64,
    /// A key that never sounds (a broken solenoid).
    pub dead: bool,
}

impl HiddenKey {
    /// Whether a strike at duty `d` sounds.
    pub fn sounds_at(&self, d: f64) -> bool {
        !self.dead && d >= self.softest
    }

    /// The press delay of a strike at duty `d`, ms.
    pub fn delay_at(&self, d: f64) -> f64 {
        if self.softest >= 1.0 {
            return self.press_delay_ms;
        }
        let x = ((1.0 - d) / (1.0 - self.softest)).clamp(0.0, 1.0);
        self.press_delay_ms + (self.soft_press_delay_ms - self.press_delay_ms) * x
    }

    /// The loudness on the velocity scale of a strike at duty `d` (0 if silent).
    pub fn loudness_at(&self, d: f64) -> f64 {
        if !self.sounds_at(d) {
            return 0.0;
        }
        crate::fit::loudness(d, self.softest)
    }
}

/// The room and the recorder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    /// Samples a second.
    pub rate: u32,
    /// How long before the score's time 0 the recording starts, ms.
    pub capture_offset_ms: f64,
    /// Signal-to-noise ratio, dB (`None`: no noise).
    pub snr_db: Option<f64>,
    /// A reverberant room.
    pub reverb: bool,
    /// A mechanical thump before each string (`None`: none).
    pub thump: Option<Thump>,
    /// The noise's and phases' seed.
    pub seed: u64,
}

/// A mechanical thump before each string.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Thump {
    /// The first model: 4 ms of white noise decaying with a 1 ms time constant, 12 ms before
    /// the string, its amplitude the string's.
    Click,
    /// A solenoid's thump, a few ms before the string: see [`Solenoid`].
    Solenoid(Solenoid),
}

/// A solenoid's mechanical thump: the plunger hitting its stop (or the key its bed) a few ms
/// before the hammer reaches the string. Two parts, from one impact:
///
/// - **a click**: white noise decaying with a 0.4 ms time constant (broadband, over about
///   2 ms);
/// - **the case's thud**: two of its modes, one drawn from 60–150 Hz (8 ms time constant),
///   one from 150–400 Hz (4 ms), at 0.7 and 0.5 of the click's amplitude, each starting as an
///   impulse response does (a sine from 0). Low: in the two lowest octaves they lie among the
///   string's own first partials, and decay over 20–30 ms, as long as a bass key's first
///   period or two.
///
/// Its lead before the string is drawn for each strike from [`lead_ms`](Self::lead_ms). Its
/// amplitude (the click's at its start, the modes' envelopes') is [`level_db`](Self::level_db)
/// against the key's string at full power (the string's RMS just after its onset), times the
/// strike's duty: the impact grows with the solenoid's drive, but far less than the string's
/// sound, which falls 36 dB from full power to the softest strike while the duty falls by
/// a half or less (6 dB). [`Solenoid::ROBOT`] is the issue's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solenoid {
    /// How long before the string the thump starts, ms: drawn uniformly for each strike.
    pub lead_ms: (f64, f64),
    /// Its amplitude at full power against the key's string at full power, dB.
    pub level_db: f64,
}

impl Solenoid {
    /// The thump of the recordings: 2–5 ms before the string, −20 dB against the
    /// string at full power. At the softest strikes (the string at −36 dB, the duty about
    /// half) the thump is then 10 dB louder than the string over its few ms, and the thud's
    /// modes, in a bass key's own bands, about as loud as its soft string there; at full
    /// power the string is 20 dB over it.
    pub const ROBOT: Self = Self {
        lead_ms: (2.0, 5.0),
        level_db: -12.0,
    };

    /// Adds one thump to `x` (`rate` Hz) before a string starting at sample `string_at`,
    /// `amp` its amplitude; its lead, modes and noise drawn from `rng`.
    pub fn add(&self, x: &mut [f64], rate: f64, string_at: f64, amp: f64, rng: &mut Rng) {
        let lead = rng.range(self.lead_ms.0, self.lead_ms.1);
        let start = (string_at - lead / 1000.0 * rate).round().max(0.0) as usize;
        let modes = [
            (rng.range(60.0, 150.0), 0.008, 0.7),
            (rng.range(150.0, 400.0), 0.004, 0.5),
        ];
        for n in 0..(0.040 * rate) as usize {
            let t = n as f64 / rate;
            let click = rng.normal() * (-t / 0.0004).exp();
            let thud: f64 = modes
                .iter()
                .map(|&(f, tau, a)| a * (-t / tau).exp() * (std::f64::consts::TAU * f * t).sin())
                .sum();
            if let Some(y) = x.get_mut(start + n) {
                *y += amp * (click + thud);
            }
        }
    }
}

/// The RMS of a synthetic string of amplitude 1 just after its onset (10 partials of
/// amplitude 1/h).
pub const STRING_RMS: f64 = 0.880;

/// A small deterministic generator (SplitMix64).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// Seeded.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Uniform in 0..1.
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `lo..hi`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// A hidden robot for keys `low..=high`: press delays 5–40 ms at full power, 5–25 ms more
/// at the softest; softest duties from `softest.0` to `softest.1`; gains over 12 dB.
pub fn hidden_robot(low: u8, high: u8, softest: (f64, f64), seed: u64) -> Vec<HiddenKey> {
    let mut rng = Rng::new(seed);
    (low..=high)
        .map(|_| {
            let press = rng.range(5.0, 40.0);
            HiddenKey {
                press_delay_ms: press,
                soft_press_delay_ms: press + rng.range(5.0, 25.0),
                softest: rng.range(softest.0, softest.1),
                gain: 0.25 * 10f64.powf(rng.range(-0.6, 0.0)),
                dead: false,
            }
        })
        .collect()
}

/// Moves each key's softest duty just above any level of the score that would sound
/// fainter than `floor` on the velocity scale ([`db_of_loudness`](crate::fit::db_of_loudness) against the key's
/// full power): such a strike is under the noise of a real room, and no method can tell it
/// from silence (the accuracy example measures where that floor lies).
pub fn clear_of_floor(
    keys: &mut [HiddenKey],
    score: &Score,
    robot: &orch_robot::Robot,
    floor: f64,
) {
    for (i, k) in keys.iter_mut().enumerate() {
        let note = score.low + i as u8;
        for &v in &score.velocities {
            let d = duty(robot, note, v);
            let l = k.loudness_at(d);
            if l > 0.0 && l < floor {
                k.softest = d + 0.002;
            }
        }
    }
}

/// The strike duty (0..=1) the robot plays `velocity` at on `note`.
pub fn duty(robot: &orch_robot::Robot, note: u8, velocity: u8) -> f64 {
    let low = robot.config.range.low().get();
    let touch = robot.config.dynamics.keys[usize::from(note - low)];
    f64::from(
        touch
            .strike_duty(orch_core::Velocity::new(velocity).expect("0..=127"))
            .get(),
    ) / 4095.0
}

/// Where each strike of the score sounds in the recording: (strike index, onset ms), for the
/// strikes that sound.
pub fn onsets(
    score: &Score,
    robot: &orch_robot::Robot,
    keys: &[HiddenKey],
    room: &Room,
) -> Vec<(usize, f64)> {
    score
        .schedule()
        .iter()
        .enumerate()
        .filter(|(_, s)| s.output.is_none())
        .filter_map(|(i, s)| {
            let k = &keys[usize::from(s.note - score.low)];
            let d = duty(robot, s.note, s.velocity);
            k.sounds_at(d).then(|| {
                (
                    i,
                    f64::from(s.at_ms) + room.capture_offset_ms + k.delay_at(d),
                )
            })
        })
        .collect()
}

/// Records the score played by the hidden robot in the room.
pub fn record(
    score: &Score,
    robot: &orch_robot::Robot,
    keys: &[HiddenKey],
    room: &Room,
) -> Recording {
    record_strikes(
        &score.schedule(),
        score.low,
        f64::from(score.length_ms()),
        robot,
        keys,
        room,
    )
}

/// Records any strikes (each held [`NOTE_MS`]) played by the hidden robot whose lowest key is
/// `low`, `length_ms` long from the score's time 0.
pub fn record_strikes(
    schedule: &[crate::Strike],
    low: u8,
    length_ms: f64,
    robot: &orch_robot::Robot,
    keys: &[HiddenKey],
    room: &Room,
) -> Recording {
    let mut rng = Rng::new(room.seed ^ 0x5EED);
    let x = strings(schedule, low, length_ms, robot, keys, room, &mut rng);
    in_room(x, room, &mut rng)
}

/// The strings (and thumps) of `schedule`'s strikes, dry, `length_ms` from the score's time
/// 0 plus the capture offset and 500 ms.
pub(crate) fn strings(
    schedule: &[crate::Strike],
    low: u8,
    length_ms: f64,
    robot: &orch_robot::Robot,
    keys: &[HiddenKey],
    room: &Room,
    rng: &mut Rng,
) -> Vec<f64> {
    let rate = f64::from(room.rate);
    let total_ms = length_ms + room.capture_offset_ms + 500.0;
    let mut x = vec![0.0f64; (total_ms / 1000.0 * rate) as usize];
    for s in schedule.iter().filter(|s| s.output.is_none()) {
        let k = &keys[usize::from(s.note - low)];
        let d = duty(robot, s.note, s.velocity);
        if !k.sounds_at(d) {
            continue;
        }
        let onset_ms = f64::from(s.at_ms) + room.capture_offset_ms + k.delay_at(d);
        let amp = k.gain * 10f64.powf(crate::fit::db_of_loudness(k.loudness_at(d)) / 20.0);
        let f0 = 440.0 * 2f64.powf((f64::from(s.note) - 69.0) / 12.0);
        let tau0 = 1.2 * 2f64.powf(-(f64::from(s.note) - 36.0) / 30.0);
        let start = onset_ms / 1000.0 * rate;
        let damper_s = (f64::from(s.at_ms + NOTE_MS) + room.capture_offset_ms + 25.0 - onset_ms)
            .max(0.0)
            / 1000.0;
        let end = ((start + (damper_s + 0.3) * rate) as usize).min(x.len());
        let first = start.ceil() as usize;
        let partials: Vec<(f64, f64, f64, f64)> = (1..=10)
            .map(|h| {
                let h = f64::from(h);
                let f = h * f0 * (1.0 + 1e-4 * h * h).sqrt();
                (
                    f,
                    1.0 / h,
                    tau0 / (1.0 + 0.3 * (h - 1.0)),
                    rng.range(0.0, std::f64::consts::TAU),
                )
            })
            .filter(|p| p.0 < 0.45 * rate)
            .collect();
        for (n, y) in x.iter_mut().enumerate().take(end).skip(first) {
            let t = (n as f64 - start) / rate;
            let attack = if t < 0.003 {
                0.5 - 0.5 * (std::f64::consts::PI * t / 0.003).cos()
            } else {
                1.0
            };
            let damp = if t > damper_s {
                (-(t - damper_s) / 0.040).exp()
            } else {
                1.0
            };
            let mut v = 0.0;
            for &(f, a, tau, ph) in &partials {
                v += a * (-t / tau).exp() * (2.0 * std::f64::consts::PI * f * t + ph).sin();
            }
            *y += amp * attack * damp * v;
        }
        match room.thump {
            Some(Thump::Click) => {
                let t0 = ((onset_ms - 12.0) / 1000.0 * rate).max(0.0) as usize;
                for n in 0..(0.004 * rate) as usize {
                    if let Some(y) = x.get_mut(t0 + n) {
                        *y += amp * rng.normal() * (-(n as f64) / (0.001 * rate)).exp();
                    }
                }
            }
            Some(Thump::Solenoid(t)) => {
                let a = k.gain * STRING_RMS * 10f64.powf(t.level_db / 20.0) * d;
                t.add(&mut x, rate, start, a, rng);
            }
            None => {}
        }
    }
    x
}

/// `x` in the room: its reverberation and noise (drawn from `rng`), as a recording.
pub(crate) fn in_room(mut x: Vec<f64>, room: &Room, rng: &mut Rng) -> Recording {
    let rate = f64::from(room.rate);
    if room.reverb {
        let mut wet = vec![0.0f64; x.len()];
        for delay_ms in [29.7, 37.1, 41.1, 43.7] {
            let dl = (delay_ms / 1000.0 * rate) as usize;
            // Gain for a 0.6 s reverberation time (60 dB down).
            let g = 10f64.powf(-3.0 * delay_ms / 1000.0 / 0.6);
            let mut y = vec![0.0f64; x.len()];
            for n in 0..x.len() {
                y[n] = x[n] + if n >= dl { g * y[n - dl] } else { 0.0 };
            }
            for (w, v) in wet.iter_mut().zip(&y) {
                *w += v;
            }
        }
        for (v, w) in x.iter_mut().zip(&wet) {
            *v += 0.3 / 4.0 * (w - *v);
        }
    }
    if let Some(snr) = room.snr_db {
        let from = ((room.capture_offset_ms + f64::from(crate::score::LEAD_IN_MS)) / 1000.0 * rate)
            as usize;
        let span = &x[from.min(x.len())..];
        let power = span.iter().map(|v| v * v).sum::<f64>() / span.len().max(1) as f64;
        let sigma = (power / 10f64.powf(snr / 10.0)).sqrt();
        for v in &mut x {
            *v += sigma * rng.normal();
        }
    }
    Recording::from_samples(room.rate, x.into_iter().map(|v| v as f32).collect())
}

/// How far a calibration is from the hidden robot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Errors {
    /// Each measured press delay's error: (note, velocity, measured − hidden, ms).
    pub strikes: Vec<(u8, u8, f64)>,
    /// The largest error of a measured press delay (each sounding level), ms.
    pub delay_max_ms: f64,
    /// The median of those errors, ms.
    pub delay_median_ms: f64,
    /// The largest error of a measured press delay on keys from E3 (note 52) up, ms.
    pub delay_max_from_e3_ms: f64,
    /// The largest error of a fitted `press_delay` (full power), ms.
    pub press_delay_max_ms: f64,
    /// The largest error of the velocity curve, in velocity steps: the calibrated robot
    /// file's curve played on the hidden key, |loudness heard − velocity asked| over every
    /// velocity 1..=127 (infinite where a velocity makes no sound).
    pub velocity_max_steps: f64,
    /// The median over keys of each key's largest velocity error.
    pub velocity_median_steps: f64,
    /// Keys whose velocity curve is more than 3 steps off somewhere (issue 19's bound), or
    /// whose velocity 1 makes no sound.
    pub velocity_over_3: Vec<u8>,
    /// Of those, the keys whose velocity 1 makes no sound.
    pub velocity_1_silent: Vec<u8>,
    /// Keys whose softest sounding level is not the hidden one.
    pub softest_wrong: Vec<u8>,
    /// Keys that sounded but were not fitted.
    pub missed: Vec<u8>,
}

/// Compares a calibration (and the robot.toml written from it) with the hidden robot.
pub fn errors(
    cal: &crate::Calibration,
    calibrated: &orch_robot::Robot,
    input: &orch_robot::Robot,
    keys: &[HiddenKey],
    score: &Score,
) -> Errors {
    let mut e = Errors::default();
    let mut delays = Vec::new();
    let mut per_key_velocity = Vec::new();
    for (k, hidden) in cal.keys.iter().zip(keys) {
        let note = k.note;
        let want_softest = score
            .velocities
            .iter()
            .copied()
            .find(|&v| hidden.sounds_at(duty(input, note, v)));
        if want_softest != k.softest_velocity {
            e.softest_wrong.push(note);
        }
        if hidden.dead {
            continue;
        }
        let Some(f) = k.fit else {
            e.missed.push(note);
            continue;
        };
        for l in &k.levels {
            if let Some(d) = l.press_delay_ms {
                let truth = hidden.delay_at(duty(input, note, l.velocity));
                delays.push((d - truth).abs());
                e.strikes.push((note, l.velocity, d - truth));
                if note >= 52 {
                    e.delay_max_from_e3_ms = e.delay_max_from_e3_ms.max((d - truth).abs());
                }
            }
        }
        e.press_delay_max_ms = e
            .press_delay_max_ms
            .max((f.press_delay_ms - hidden.press_delay_ms).abs());
        let mut worst: f64 = 0.0;
        for v in 1..=127u8 {
            let d = duty(calibrated, note, v);
            let heard = hidden.loudness_at(d);
            worst = worst.max(if heard == 0.0 {
                f64::INFINITY
            } else {
                (heard - f64::from(v)).abs()
            });
        }
        if worst > 3.0 {
            e.velocity_over_3.push(note);
        }
        if !hidden.sounds_at(duty(calibrated, note, 1)) {
            e.velocity_1_silent.push(note);
        }
        per_key_velocity.push(worst);
    }
    e.delay_max_ms = delays.iter().copied().fold(0.0, f64::max);
    e.delay_median_ms = crate::onset::median(&mut delays);
    e.velocity_max_steps = per_key_velocity.iter().copied().fold(0.0, f64::max);
    e.velocity_median_steps = crate::onset::median(&mut per_key_velocity);
    e
}

/// A sample as a capture device reading `S32_LE` delivers it (full scale is `i32::MAX`).
pub fn s32(x: f32) -> i32 {
    (f64::from(x.clamp(-1.0, 1.0)) * 2_147_483_647.0).round() as i32
}

/// Mono samples as raw `S32_LE` frames: what ALSA's `file` plugin plays as a microphone for a
/// capture that negotiates S32_LE mono (the `mic` feature's first choice on a device, such as
/// the `null` plugin, that takes every format).
pub fn raw_s32(samples: &[f32]) -> Vec<u8> {
    samples.iter().flat_map(|&x| s32(x).to_le_bytes()).collect()
}

/// An ALSA configuration (for an `asoundrc`) defining the capture PCM `name` as a microphone
/// that plays the raw frames of `infile` (ALSA's `file` plugin over its `null` one): the tests'
/// sound card. At the file's end the plugin goes on giving the last samples it read; a FIFO
/// that is held open without data makes a microphone that stops.
pub fn file_mic_conf(name: &str, infile: &std::path::Path) -> String {
    format!(
        "pcm.{name} {{\n  type file\n  slave.pcm \"null\"\n  file \"/dev/null\"\n  infile \"{}\"\n  \
         format \"raw\"\n}}\n",
        infile.display()
    )
}
