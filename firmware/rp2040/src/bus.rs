//! The I2C bus's health: a time limit on every board operation, and bus recovery.
//!
//! The RP2040's I2C controller has no timeout of its own: a board that holds SCL low (hung)
//! would keep a write, and the whole interpreter loop, waiting until the watchdog reset the
//! Pico. Every operation runs [`within`] [`TIMEOUT`] instead; one that runs out has the
//! controller abort the transfer (it ends it with a STOP once the bus lets it), and the loop
//! goes on (MIDI thru, USB, the guard's timers) with every board set aside. The retry round
//! then calls [`recover`] before it initialises boards again: it waits for the aborted
//! transfer to end, and clears a bus whose SDA a board holds low (a board that lost its place
//! in a byte, for example when the Pico reset in the middle of a write): up to nine clock
//! pulses by hand and a STOP, the I2C specification's bus clear.

use core::future::Future;

use embassy_rp::pac;
use embassy_time::{with_timeout, Duration, Instant, Timer};

/// The longest a board operation may take: a write is 38 SCL periods (95 µs at 400 kHz), an
/// initialisation two writes.
pub const TIMEOUT: Duration = Duration::from_millis(2);

/// The bus's pins (`Pins` in `main.rs`): GP4 SDA, GP5 SCL.
const SDA: usize = 4;
const SCL: usize = 5;
/// IO_BANK0 function numbers (the RP2040 datasheet's GPIO function table).
const FUNC_I2C: u8 = 3;
const FUNC_SIO: u8 = 5;
/// Half a clock pulse of the bus clear: about 100 kHz.
const HALF_PULSE_US: u64 = 5;

/// Why a board operation did not succeed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The board did not acknowledge, or the bus was lost: try again, then set it aside.
    Failed,
    /// It ran out of [`TIMEOUT`]: the bus is hung; every board is set aside until [`recover`].
    TimedOut,
}

/// Runs one board operation within [`TIMEOUT`]. On a timeout the controller is told to abort
/// the transfer.
pub async fn within<T, E>(op: impl Future<Output = Result<T, E>>) -> Result<T, Fault> {
    match with_timeout(TIMEOUT, op).await {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(_)) => Err(Fault::Failed),
        Err(_) => {
            pac::I2C0.ic_enable().modify(|w| w.set_abort(true));
            Err(Fault::TimedOut)
        }
    }
}

/// SDA's and SCL's levels as the pads read them (whatever drives them).
fn lines() -> (bool, bool) {
    let v = pac::SIO.gpio_in(0).read();
    (v & (1 << SDA) != 0, v & (1 << SCL) != 0)
}

/// Makes the bus usable again if it can, and says whether it is: not while an aborted
/// transfer has yet to end or a board holds SCL low (nothing to do but wait for it); SDA held
/// low is cleared by hand.
pub async fn recover() -> bool {
    let i2c = pac::I2C0;
    if i2c.ic_enable().read().abort() || i2c.ic_status().read().mst_activity() {
        return false;
    }
    // The aborted transfer's abort and interrupts, read away: the next transfer would take
    // them for its own.
    let _ = i2c.ic_clr_tx_abrt().read();
    let _ = i2c.ic_clr_intr().read();
    let (sda, scl) = lines();
    if !scl {
        return false;
    }
    if sda {
        return true;
    }
    // The pins as open-drain outputs by hand: driven low (output enabled, level 0) or let go
    // (output disabled; the bus's pull-ups raise it).
    let (sda_bit, scl_bit) = (1u32 << SDA, 1u32 << SCL);
    pac::SIO
        .gpio_out(0)
        .value_clr()
        .write_value(sda_bit | scl_bit);
    let_go(sda_bit | scl_bit);
    function(FUNC_SIO);
    for _ in 0..9 {
        if lines().0 {
            break;
        }
        drive_low(scl_bit);
        Timer::after_micros(HALF_PULSE_US).await;
        let_go(scl_bit);
        Timer::after_micros(HALF_PULSE_US).await;
    }
    // A STOP: SDA low while SCL is high, then let go.
    drive_low(sda_bit);
    Timer::after_micros(HALF_PULSE_US).await;
    let_go(sda_bit);
    Timer::after_micros(HALF_PULSE_US).await;
    function(FUNC_I2C);
    let (sda, scl) = lines();
    sda && scl
}

/// Both bus pins to IO_BANK0 function `f` (I2C, or SIO for the bus clear).
fn function(f: u8) {
    for pin in [SDA, SCL] {
        pac::IO_BANK0.gpio(pin).ctrl().write(|w| w.set_funcsel(f));
    }
}

/// Drives the pins in `mask` low (as SIO outputs at level 0).
fn drive_low(mask: u32) {
    pac::SIO.gpio_oe(0).value_set().write_value(mask);
}

/// Lets the pins in `mask` go (the pull-ups raise them).
fn let_go(mask: u32) {
    pac::SIO.gpio_oe(0).value_clr().write_value(mask);
}

/// For the panic handler: `frame` written to every board now (outputs 0, or every channel
/// off), through the I2C registers, with interrupts off and every wait bounded (a hung bus is
/// given up on: the watchdog's reset and power-up then release the keys). `addresses`: the
/// boards' 7-bit addresses.
pub fn write_all_now(addresses: &[u8], frame: &[u8]) {
    let i2c = pac::I2C0;
    // End the transfer that was going on, if any.
    i2c.ic_enable().modify(|w| w.set_abort(true));
    spin_until(1_000, || !i2c.ic_enable().read().abort());
    for &address in addresses {
        i2c.ic_enable().write(|w| w.set_enable(false));
        i2c.ic_tar().write(|w| w.set_ic_tar(address as u16));
        i2c.ic_enable().write(|w| w.set_enable(true));
        let _ = i2c.ic_clr_intr().read();
        for (n, &byte) in frame.iter().enumerate() {
            i2c.ic_data_cmd().write(|w| {
                w.set_dat(byte);
                w.set_stop(n + 1 == frame.len());
            });
        }
        spin_until(1_000, || {
            let r = i2c.ic_raw_intr_stat().read();
            r.stop_det() || r.tx_abrt()
        });
    }
}

/// Spins until `done` or `limit_us` have passed (the timer's counter, readable with
/// interrupts off).
fn spin_until(limit_us: u64, mut done: impl FnMut() -> bool) {
    let end = Instant::now() + Duration::from_micros(limit_us);
    while !done() && Instant::now() < end {}
}
