//! The PCA9555 / TCA9555 register map (command bytes), as in the NXP and TI datasheets.
//!
//! Registers come in pairs, port 0 then port 1. After the command byte the device moves to the
//! other register of the pair with each further data byte, so `[OUTPUT_PORT_0, lo, hi]` sets
//! both output ports in one transaction, and a two-byte read from `INPUT_PORT_0` returns both
//! input ports.

/// Input port 0 (read-only): the logic levels on pins IO0_0..IO0_7.
pub const INPUT_PORT_0: u8 = 0x00;
/// Input port 1 (read-only): the logic levels on pins IO1_0..IO1_7.
pub const INPUT_PORT_1: u8 = 0x01;
/// Output port 0: the levels driven on IO0_0..IO0_7 where they are outputs. Power-up value 0xFF.
pub const OUTPUT_PORT_0: u8 = 0x02;
/// Output port 1: the levels driven on IO1_0..IO1_7 where they are outputs. Power-up value 0xFF.
pub const OUTPUT_PORT_1: u8 = 0x03;
/// Polarity inversion port 0: a 1 inverts the matching input bit. Power-up value 0x00.
pub const POLARITY_INVERSION_0: u8 = 0x04;
/// Polarity inversion port 1: a 1 inverts the matching input bit. Power-up value 0x00.
pub const POLARITY_INVERSION_1: u8 = 0x05;
/// Configuration port 0: a 0 makes the pin an output, a 1 an input. Power-up value 0xFF.
pub const CONFIGURATION_0: u8 = 0x06;
/// Configuration port 1: a 0 makes the pin an output, a 1 an input. Power-up value 0xFF.
pub const CONFIGURATION_1: u8 = 0x07;

/// Configuration value making all eight pins of a port outputs (bit = 0 means output).
pub const CONFIGURATION_ALL_OUTPUTS: u8 = 0x00;
/// Configuration value making all eight pins of a port inputs: the power-up state.
pub const CONFIGURATION_ALL_INPUTS: u8 = 0xFF;
/// What both output registers hold after power-up or reset: every bit 1.
pub const OUTPUT_POWER_UP: u16 = 0xFFFF;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn register_pairs_are_port_0_then_port_1() {
        for (p0, p1) in [
            (INPUT_PORT_0, INPUT_PORT_1),
            (OUTPUT_PORT_0, OUTPUT_PORT_1),
            (POLARITY_INVERSION_0, POLARITY_INVERSION_1),
            (CONFIGURATION_0, CONFIGURATION_1),
        ] {
            assert_eq!(p0 % 2, 0);
            assert_eq!(p1, p0 + 1);
        }
    }
}
