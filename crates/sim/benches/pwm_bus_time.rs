//! Bus time of a key change on a PCA9685 PWM board against a PCA9555 on/off board, measured
//! on the virtual bus through `orch-boards`' real drivers (prints; not a test).
//!
//! ```sh
//! cargo bench -p orch-sim --bench pwm_bus_time
//! ```
//!
//! A transaction costs START + 9 bits a byte (the address byte too) + STOP. The PCA9555 is a
//! Fast-mode part (400 kHz at most); the PCA9685 is Fast-mode Plus (1 MHz), so on a real bus
//! the 1 MHz column is the PCA9685's alone.

use embedded_hal::delay::DelayNs;
use orch_boards::{Pca9555 as IoDriver, Pca9685 as PwmDriver};
use orch_sim::{BusClock, Pca9555, Pca9685, VirtualBus};

struct NoWait;

impl DelayNs for NoWait {
    fn delay_ns(&mut self, _: u32) {}
}

/// Transactions, bit-times and busy time (ns) of what `f` does on the bus after `setup`.
fn measure<D>(
    clock: BusClock,
    setup: impl FnOnce(VirtualBus) -> D,
    bus_of: impl Fn(&mut D) -> &mut VirtualBus,
    f: impl FnOnce(&mut D),
) -> (u64, u64, u64) {
    let mut bus = VirtualBus::new(clock);
    bus.attach(Pca9555::new(0x21));
    bus.attach(Pca9685::new(0x40));
    let mut dev = setup(bus);
    let before = bus_of(&mut dev).stats();
    f(&mut dev);
    let after = bus_of(&mut dev).stats();
    (
        after.transactions - before.transactions,
        after.bit_times - before.bit_times,
        after.busy_nanos - before.busy_nanos,
    )
}

/// A PCA9685 driver, initialised at 1526 Hz: its cache knows every channel is off.
fn pwm(bus: VirtualBus) -> PwmDriver<VirtualBus> {
    let mut dev = PwmDriver::new(bus, 0x40);
    dev.init(1526, &mut NoWait).unwrap();
    dev
}

fn pwm_case(clock: BusClock, f: fn(&mut PwmDriver<VirtualBus>)) -> (u64, u64, u64) {
    measure(clock, pwm, |d| d.bus_mut(), f)
}

fn main() {
    let clocks = [
        ("83.33 kHz", BusClock::THESIS),
        ("400 kHz", BusClock::FAST),
        ("1 MHz", BusClock::from_hz(1_000_000)),
    ];
    type PwmCase = fn(&mut PwmDriver<VirtualBus>);
    let pwm_cases: [(&str, PwmCase); 5] = [
        (
            "PCA9685 key change: one channel, `[LEDn_ON_L, 4 bytes]`",
            |d| {
                d.set_duty(8, 4095).unwrap();
            },
        ),
        ("PCA9685 strike then hold: two channel writes", |d| {
            d.set_duty(8, 4095).unwrap();
            d.set_duty(8, 1434).unwrap();
        }),
        ("PCA9685 chord of 3 neighbouring keys: one run", |d| {
            let mut duties = [0; 16];
            duties[4..7].copy_from_slice(&[4095, 3000, 2000]);
            d.set_duties(&duties).unwrap();
        }),
        ("PCA9685 all 16 channels: one 65-byte write", |d| {
            d.set_duties(&[2000; 16]).unwrap();
        }),
        ("PCA9685 all off: `[ALL_LED_OFF_H, 0x10]`", |d| {
            d.all_off().unwrap();
        }),
    ];

    println!("Bus time of a key change (virtual bus, through orch-boards' drivers)\n");
    print!("| change | transactions | bit-times |");
    clocks.iter().for_each(|(name, _)| print!(" {name} |"));
    println!("\n|---|---|---|---|---|---|");
    let row = |label: &str, runs: Vec<(u64, u64, u64)>| {
        let (tx, bits, _) = runs[0];
        assert!(runs.iter().all(|r| (r.0, r.1) == (tx, bits)));
        print!("| {label} | {tx} | {bits} |");
        runs.iter()
            .for_each(|r| print!(" {:.0} µs |", r.2 as f64 / 1_000.0));
        println!();
    };
    let io: Vec<_> = clocks
        .iter()
        .map(|&(_, clock)| {
            measure(
                clock,
                |mut bus| {
                    IoDriver::new(&mut bus, 0x21).init().unwrap();
                    bus
                },
                |bus| bus,
                |bus| IoDriver::new(bus, 0x21).set_outputs(0x0100).unwrap(),
            )
        })
        .collect();
    row("PCA9555 key change: `[0x02, lo, hi]`", io);
    for (label, f) in pwm_cases {
        row(label, clocks.iter().map(|&(_, c)| pwm_case(c, f)).collect());
    }
    let mut chip = Pca9685::new(0x40);
    let power_up = chip.period_nanos();
    chip.write_frame(&[0xFE, 3]); // asleep at power-up: PRE_SCALE is writable
    println!(
        "\nA PCA9685 applies a new duty at its next PWM period: up to {:.0} µs after the STOP at \
         1526 Hz (prescale 3), {:.0} µs at its power-up 200 Hz.",
        chip.period_nanos() as f64 / 1_000.0,
        power_up as f64 / 1_000.0
    );
}
