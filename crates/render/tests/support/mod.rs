//! Test support: a SoundFont written here, whose sound starts at full level on its first
//! sample, so a strike's onset in the audio is the strike's own sample (an installed font's
//! samples begin with tens to hundreds of samples of silence, which differ by note).

use std::sync::Arc;

use orch_render::SoundFont;

use testkit::sf2;

/// A SoundFont 2 with one preset (bank 0, program 0) of one sample: a square wave of ±0.5
/// full scale, 100 samples a period, looped, recorded at `rate` Hz with root key 60. Its first
/// sample is at +0.5, and its volume envelope has no delay and no attack: a voice's first
/// output sample is already far above −100 dBFS.
pub fn square_font(rate: u32) -> Arc<SoundFont> {
    font(rate, true)
}

/// The same with the SF2 default volume envelope (a delay of −12 000 timecents, 1 ms, and an
/// attack as long): its voices begin 41 samples after they start at 44.1 kHz.
pub fn square_font_with_default_envelope(rate: u32) -> Arc<SoundFont> {
    font(rate, false)
}

fn font(rate: u32, instant: bool) -> Arc<SoundFont> {
    let period = 100usize;
    let wave: Vec<i16> = (0..20 * period)
        .map(|i| {
            if i % period < period / 2 {
                16384
            } else {
                -16384
            }
        })
        .collect();
    // delayVolEnv and attackVolEnv at their shortest (nothing): the SF2 default, -12000
    // timecents (1 ms), delays every voice by 41 samples at 44.1 kHz in rustysynth.
    let mut generators = Vec::new();
    if instant {
        generators.extend([
            (sf2::DELAY_VOL_ENV, sf2::NO_TIME),
            (sf2::ATTACK_VOL_ENV, sf2::NO_TIME),
        ]);
    }
    generators.push((sf2::SAMPLE_MODES, 1)); // loop continuously
    sf2::one_sample(&wave, rate, &generators)
}
