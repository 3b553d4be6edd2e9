//! The robot the Pico firmware's `pca9685` build plays: orch-core's settings, in one place for
//! the firmware and for the host's `orch-rp2040-expect` (both depend on this crate), so the
//! emulator tests compare the firmware with orch-core run on exactly these settings.
//!
//! A piano and a General MIDI drum kit, on five PCA9685 PWM boards:
//!
//! - the thesis's keyboard (61 keys, notes 36..=96 folded, orch's default guard) on every
//!   channel but 10, on the boards at 0x40..=0x43, 16/16/16/13 keys from channel 0 (keys 0..=60,
//!   as the build had them before the kit), played with [`Dynamics::PWM`]: a press is a strike
//!   at the duty its velocity gives (45 % at velocity 1 to 100 % at 127) for 40 ms, then a
//!   hold at 35 % until its release;
//! - the kit ([`KIT`]) on channel 10, nine beaters on a fifth board at 0x44, channels 0..=8
//!   (keys 61..=69): a hit fires its beater for a pulse of [`Pulse::DRUM`] (8 ms at velocity 1
//!   to 20 ms at 127, at the velocity's duty on the same curve, no hold) that ends by itself
//!   whatever the Note-Off does, and the beater strikes again no sooner than its 40 ms rebound.
//!
//! The kit has a board of its own so that the keyboard's boards and keys stay exactly as they
//! were (key `k` on board `k / 16`), and the drums' coils, larger than the keys', can have their
//! own supply on their own board.

#![no_std]

use orch_core::{
    BoardSpan, ChannelMask, Config, Dynamics, GuardConfig, Interpreter, KeyRange, Layout,
    OutOfRange, Overlap, Pulse, Strikes,
};

/// The PCA9685 boards' 7-bit addresses: A5..A0 = 0, 1, 2, 3 (the keyboard), 4 (the kit).
pub const PCA9685_ADDRESSES: [u8; BOARDS] = [0x40, 0x41, 0x42, 0x43, 0x44];

/// How many boards: four for the keyboard, one for the kit.
pub const BOARDS: usize = 5;

/// The keyboard's keys (notes 36..=96).
pub const KEYBOARD_KEYS: usize = 61;

/// Every output: the keyboard's keys, then the kit's beaters.
pub const OUTPUTS: usize = KEYBOARD_KEYS + KIT.len();

/// Channel 10 (0-based 9), General MIDI's percussion: the kit's, and not the keyboard's.
pub const DRUM_CHANNEL: u8 = 9;

/// The kit's beaters in output order (keys 61..=69, the fifth board's channels 0..=8) and the
/// General MIDI notes each plays.
pub const KIT: [(&[u8], Pulse); 9] = [
    (&[35, 36], Pulse::DRUM), // kick: acoustic and bass drum 1
    (&[38, 40], Pulse::DRUM), // snare: acoustic and electric
    (&[42, 46], Pulse::DRUM), // hi-hat: closed and open
    (&[44], Pulse::DRUM),     // hi-hat pedal
    (&[41, 43], Pulse::DRUM), // floor tom: low and high floor tom
    (&[45, 47], Pulse::DRUM), // mid tom: low and low-mid tom
    (&[48, 50], Pulse::DRUM), // high tom: hi-mid and high tom
    (&[49, 57], Pulse::DRUM), // crash: crash cymbals 1 and 2
    (&[51, 59], Pulse::DRUM), // ride: ride cymbals 1 and 2
];

/// The interpreter on [`PCA9685`]: five boards, room for its 70 outputs.
pub type Robot = Interpreter<BOARDS, OUTPUTS>;

const fn board(address: u8, keys: u8) -> BoardSpan {
    BoardSpan {
        address,
        keys,
        first_bit: 0,
    }
}

/// The PCA9685 robot's settings: [`Config::THESIS`]'s keyboard on every channel but 10 on the
/// first four boards, [`KIT`] on channel 10 on the fifth, [`Dynamics::PWM`] on every output.
/// The kit is built at compile time (`Strikes::with_kit`, a `const fn`): a kit orch-core
/// refuses does not compile.
pub const PCA9685: Config<BOARDS> = Config {
    channels: ChannelMask(!(1 << DRUM_CHANNEL)),
    range: KeyRange::THESIS,
    out_of_range: OutOfRange::Fold,
    layout: Layout {
        boards: [
            board(PCA9685_ADDRESSES[0], 16),
            board(PCA9685_ADDRESSES[1], 16),
            board(PCA9685_ADDRESSES[2], 16),
            board(PCA9685_ADDRESSES[3], 13),
            board(PCA9685_ADDRESSES[4], KIT.len() as u8),
        ],
    },
    sustain: false,
    overlap: Overlap::Restrike,
    guard: GuardConfig::DEFAULT,
    dynamics: Dynamics::PWM,
    strikes: Strikes::NONE.with_kit(ChannelMask(1 << DRUM_CHANNEL), KEYBOARD_KEYS, &KIT),
};
