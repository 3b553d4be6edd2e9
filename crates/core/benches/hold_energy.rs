//! Prints the energy a held note draws with hit-and-hold (strike at the velocity's duty, then
//! the hold duty) against full power for the whole press, on the default PWM curve
//! ([`Dynamics::PWM`]), for notes held 0.1 s to 10 s at three velocities.
//!
//! `cargo bench -p orch-core --bench hold_energy`

use orch_core::{Dynamics, Velocity};

fn main() {
    let d = Dynamics::PWM;
    println!("energy of a held note with hit-and-hold, % of full power for the whole press");
    println!(
        "(default PWM curve: strike {} ms at 45-100 %, hold at 35 %)",
        d.strike.as_micros() / 1000
    );
    println!(
        "{:>8} {:>10} {:>10} {:>10}",
        "held", "vel 1", "vel 64", "vel 127"
    );
    for held_ms in [100u32, 500, 2_000, 10_000] {
        let us = held_ms * 1000;
        let pct = |v: u8| {
            let v = Velocity::new(v).expect("a velocity");
            d.energy(0, v, us) as f64 * 100.0 / us as f64
        };
        println!(
            "{:>6} s {:>9.1}% {:>9.1}% {:>9.1}%",
            held_ms as f64 / 1000.0,
            pct(1),
            pct(64),
            pct(127)
        );
    }
}
