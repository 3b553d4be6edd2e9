//! The bytes of each transaction, built in one place for the blocking and async drivers.

use crate::registers::{CONFIGURATION_0, CONFIGURATION_ALL_OUTPUTS, INPUT_PORT_0, OUTPUT_PORT_0};

/// `[OUTPUT_PORT_0, lo, hi]`: all 16 outputs in one write (bits 0..=7 are port 0).
pub(crate) const fn outputs(value: u16) -> [u8; 3] {
    let [lo, hi] = value.to_le_bytes();
    [OUTPUT_PORT_0, lo, hi]
}

/// `[CONFIGURATION_0, 0x00, 0x00]`: all 16 pins outputs.
pub(crate) const ALL_OUTPUTS: [u8; 3] = [
    CONFIGURATION_0,
    CONFIGURATION_ALL_OUTPUTS,
    CONFIGURATION_ALL_OUTPUTS,
];

/// The command byte before a two-byte read of both output registers.
pub(crate) const READ_OUTPUTS: [u8; 1] = [OUTPUT_PORT_0];

/// The command byte before a two-byte read of both input registers.
pub(crate) const READ_INPUTS: [u8; 1] = [INPUT_PORT_0];

/// Two bytes read from a register pair, port 0 first, as one 16-bit value.
pub(crate) const fn word(bytes: [u8; 2]) -> u16 {
    u16::from_le_bytes(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_frame_puts_port_0_first() {
        assert_eq!(outputs(0x0000), [0x02, 0x00, 0x00]);
        assert_eq!(outputs(0x0001), [0x02, 0x01, 0x00]);
        assert_eq!(outputs(0x0100), [0x02, 0x00, 0x01]);
        assert_eq!(outputs(0xA55A), [0x02, 0x5A, 0xA5]);
    }

    #[test]
    fn configuration_frame_makes_every_pin_an_output() {
        assert_eq!(ALL_OUTPUTS, [0x06, 0x00, 0x00]);
    }

    #[test]
    fn word_reads_port_0_as_low_byte() {
        assert_eq!(word([0x34, 0x12]), 0x1234);
    }
}
