//! Synthetic recordings of a robot's strike outputs (a drum kit, a glockenspiel's bars),
//! their figures hidden from the analysis.
//!
//! - **The beaters** ([`HiddenOutput::beater`], a [`HiddenKey`]): a flight at full power
//!   drawn from 5–25 ms, a soft flight 3–15 ms more (at the beater's softest), a softest
//!   duty 0.2–10 points above the robot file's (so the file's softest, where a PCA9685 kit
//!   plays velocity 1, is a blank: at loudness 1, −36 dB against full power, a drum is under
//!   a 30 dB room's noise across the band anyway), a gain over 12 dB. A strike at duty `d`
//!   sounds as a key's does: after the flight at `d`, at the virtual robot's loudness.
//! - **The drums** ([`Drum`], by the output's name): from the onset on (abrupt, as a
//!   beater's contact is), the stick's click (white noise decaying in 0.5 ms, as loud as the
//!   drum), white noise decaying with one time constant and a sine from a random phase
//!   decaying with another, mixed in a share; each figure drawn around a drum's own (a kick's
//!   50–70 Hz body ringing 0.2–0.35 s, a closed hi-hat's noise dying in 30–80 ms, a crash's
//!   in 1–1.5 s, a bar's tone at its note ringing 0.5–1 s...). The note's length changes
//!   nothing.
//! - Keys and their strings as [`record`](super::record) makes them; the same room.

use super::{in_room, strings, HiddenKey, Rng, Room};
use crate::score::Score;
use crate::wav::Recording;

/// One drum's sound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drum {
    /// The tone's frequency, Hz.
    pub tone_hz: f64,
    /// The tone's time constant, s.
    pub tone_tau_s: f64,
    /// The noise's time constant, s.
    pub noise_tau_s: f64,
    /// The noise's share of the amplitude, 0..=1.
    pub noise_share: f64,
}

impl Drum {
    /// A drum like the one named `name` (a bar's tone at `note` if the name is no drum's),
    /// its figures drawn from `rng`.
    pub fn drawn(name: &str, note: u8, rng: &mut Rng) -> Self {
        // (tone Hz, tone τ s, noise τ s, noise share), each as a range.
        type R = (f64, f64);
        let (hz, tone, noise, share): (R, R, R, R) = match name {
            "kick" => ((50.0, 70.0), (0.2, 0.35), (0.01, 0.03), (0.2, 0.3)),
            "snare" => ((180.0, 250.0), (0.08, 0.15), (0.1, 0.2), (0.6, 0.8)),
            "hi-hat" => ((300.0, 500.0), (0.01, 0.02), (0.03, 0.08), (0.9, 0.97)),
            "hi-hat pedal" => ((300.0, 500.0), (0.01, 0.02), (0.02, 0.05), (0.9, 0.97)),
            "crash" => ((400.0, 700.0), (0.3, 0.6), (1.0, 1.5), (0.85, 0.95)),
            "ride" => ((400.0, 700.0), (0.6, 1.0), (0.6, 1.0), (0.6, 0.8)),
            n if n.ends_with("tom") => ((80.0, 200.0), (0.2, 0.4), (0.01, 0.03), (0.25, 0.4)),
            _ => {
                let f = 440.0 * 2f64.powf((f64::from(note) - 69.0) / 12.0);
                ((f, f), (0.5, 1.0), (0.003, 0.006), (0.1, 0.2))
            }
        };
        Self {
            tone_hz: rng.range(hz.0, hz.1),
            tone_tau_s: rng.range(tone.0, tone.1),
            noise_tau_s: rng.range(noise.0, noise.1),
            noise_share: rng.range(share.0, share.1),
        }
    }
}

/// One strike output of the hidden robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HiddenOutput {
    /// Its beater: flight (`press_delay_ms`), soft flight, softest duty, gain.
    pub beater: HiddenKey,
    /// Its sound.
    pub drum: Drum,
}

/// The strike duty (0..=1) the robot plays `velocity` at on output `key`.
pub fn duty(robot: &orch_robot::Robot, key: u8, velocity: u8) -> f64 {
    let touch = robot.config.dynamics.keys[usize::from(key)];
    f64::from(
        touch
            .strike_duty(orch_core::Velocity::new(velocity).expect("0..=127"))
            .get(),
    ) / 4095.0
}

/// Hidden figures for every strike output of `score`.
pub fn hidden_outputs(score: &Score, robot: &orch_robot::Robot, seed: u64) -> Vec<HiddenOutput> {
    let mut rng = Rng::new(seed);
    score
        .outputs
        .iter()
        .map(|o| {
            let flight = rng.range(5.0, 25.0);
            let beater = HiddenKey {
                press_delay_ms: flight,
                soft_press_delay_ms: flight + rng.range(3.0, 15.0),
                softest: f64::from(robot.mechanics.for_key(o.key).softest) / 4095.0
                    + rng.range(0.002, 0.1),
                gain: 0.3 * 10f64.powf(rng.range(-0.6, 0.0)),
                dead: false,
            };
            let drum = Drum::drawn(&o.name, o.note, &mut rng);
            HiddenOutput { beater, drum }
        })
        .collect()
}

/// The flight the calibrated robot.toml should give at duty `d` (below the beater's softest
/// too): the beater's line from full power to its softest, extended.
pub fn line_at(beater: &HiddenKey, d: f64) -> f64 {
    let x = (1.0 - d) / (1.0 - beater.softest);
    beater.press_delay_ms + (beater.soft_press_delay_ms - beater.press_delay_ms) * x
}

/// The hidden truth of one strike of output `i` at `velocity`: its flight (ms), if it sounds.
pub fn flight(
    score: &Score,
    robot: &orch_robot::Robot,
    outputs: &[HiddenOutput],
    i: usize,
    velocity: u8,
) -> Option<f64> {
    let b = &outputs[i].beater;
    let d = duty(robot, score.outputs[i].key, velocity);
    b.sounds_at(d).then(|| b.delay_at(d))
}

/// Records the score (keys and strike outputs) played by the hidden robot in the room.
pub fn record(
    score: &Score,
    robot: &orch_robot::Robot,
    keys: &[HiddenKey],
    outputs: &[HiddenOutput],
    room: &Room,
) -> Recording {
    let mut rng = Rng::new(room.seed ^ 0x5EED);
    let schedule = score.schedule();
    let length_ms = f64::from(score.length_ms());
    let mut x = strings(&schedule, score.low, length_ms, robot, keys, room, &mut rng);
    let rate = f64::from(room.rate);
    for s in &schedule {
        let Some(i) = s.output else { continue };
        let Some(flight) = flight(score, robot, outputs, i, s.velocity) else {
            continue;
        };
        let b = &outputs[i].beater;
        let d = duty(robot, score.outputs[i].key, s.velocity);
        let amp = b.gain * 10f64.powf(crate::fit::db_of_loudness(b.loudness_at(d)) / 20.0);
        let start = (f64::from(s.at_ms) + room.capture_offset_ms + flight) / 1000.0 * rate;
        add_drum(&mut x, rate, start, amp, &outputs[i].drum, &mut rng);
    }
    in_room(x, room, &mut rng)
}

/// Adds one hit of `drum` from sample `start` (fractional), amplitude `amp`.
fn add_drum(x: &mut [f64], rate: f64, start: f64, amp: f64, drum: &Drum, rng: &mut Rng) {
    let phase = rng.range(0.0, std::f64::consts::TAU);
    let long = drum.noise_tau_s.max(drum.tone_tau_s) * 7.0;
    let first = start.ceil() as usize;
    let end = ((start + long * rate) as usize).min(x.len());
    let tone = (1.0 - drum.noise_share) * std::f64::consts::SQRT_2;
    for (n, y) in x.iter_mut().enumerate().take(end).skip(first) {
        let t = (n as f64 - start) / rate;
        let noise =
            rng.normal() * (drum.noise_share * (-t / drum.noise_tau_s).exp() + (-t / 5e-4).exp());
        let body = tone
            * (-t / drum.tone_tau_s).exp()
            * (std::f64::consts::TAU * drum.tone_hz * t + phase).sin();
        *y += amp * (noise + body);
    }
}
