//! The robot the `pca9685` build plays: orch-core's settings, in one place for the firmware and
//! for the host's `orch-rp2040-expect` (which includes this file), so the emulator tests
//! compare the firmware with orch-core run on exactly these settings.
//!
//! The thesis's robot (61 keys, notes 36..=96 folded, every channel, orch's default guard) on
//! four PCA9685 PWM boards at 0x40..=0x43, 16/16/16/13 keys from channel 0, played with
//! [`Dynamics::PWM`]: a press is a strike at the duty its velocity gives (45 % at velocity 1
//! to 100 % at 127) for 40 ms, then a hold at 35 % until its release.

use orch_core::{Config, Dynamics, Layout};

/// The PCA9685 boards' 7-bit addresses: A5..A0 = 0, 1, 2, 3.
pub const PCA9685_ADDRESSES: [u8; 4] = [0x40, 0x41, 0x42, 0x43];

/// The PCA9685 robot's settings: [`Config::THESIS`] with the boards at
/// [`PCA9685_ADDRESSES`] and [`Dynamics::PWM`].
pub const PCA9685: Config<4> = Config {
    layout: Layout::sequential(PCA9685_ADDRESSES, 61),
    dynamics: Dynamics::PWM,
    ..Config::THESIS
};
