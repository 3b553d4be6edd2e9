//! Prints how many loudness levels the virtual robot tells apart on the default velocity
//! curve, against the Yamaha Disklavier's 256–512 (Yamaha's figure; see SYSTEM.md).
//!
//! `cargo bench -p orch-sim --bench velocity_levels`

use std::collections::BTreeSet;

use orch_core::{Touch, Velocity};
use orch_sim::KeyMechanics;

fn main() {
    let touch = Touch::PWM;
    let key = KeyMechanics::DEFAULT;
    let duties: BTreeSet<u16> = (1..=127u8)
        .map(|v| touch.strike_duty(Velocity::from_bits(v)).get())
        .collect();
    let heard: BTreeSet<u8> = duties.iter().filter_map(|&d| key.velocity_at(d)).collect();
    let sounding_duties = (0..=4095u16).filter(|&d| key.sounds_at(d)).count();
    let delays: BTreeSet<u32> = duties
        .iter()
        .map(|&d| key.press_delay_at(d).as_micros())
        .collect();
    println!(
        "default curve: strike at {:.0} % (velocity 1) to {:.0} % (127), the PCA9685's 12 bits",
        touch.softest.percent(),
        touch.loudest.percent()
    );
    println!(
        "velocities 1..=127 give {} distinct strike duties",
        duties.len()
    );
    println!(
        "the virtual robot hears {} distinct loudness levels (MIDI's 127: {:.2}x the Disklavier's 256, {:.2}x its 512)",
        heard.len(),
        heard.len() as f64 / 256.0,
        heard.len() as f64 / 512.0
    );
    println!(
        "the chip has {} sounding strike duties on such a key ({:.1}x 256, {:.1}x 512): \
         MIDI velocity, not the board, is the limit",
        sounding_duties,
        sounding_duties as f64 / 256.0,
        sounding_duties as f64 / 512.0
    );
    println!(
        "press delays from {:.1} ms (127) to {:.1} ms (1): {} distinct",
        key.press_delay_at(touch.loudest.get()).as_micros() as f64 / 1000.0,
        key.press_delay_at(touch.softest.get()).as_micros() as f64 / 1000.0,
        delays.len()
    );
}
