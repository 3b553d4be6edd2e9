//! A register model of the NXP PCA9555 (and TI TCA9555) 16-bit I2C I/O expander, the finger
//! boards' chip.
//!
//! Eight registers in four pairs, selected by the command byte:
//!
//! | command | register | power-up |
//! |---|---|---|
//! | [`INPUT_PORT_0`], [`INPUT_PORT_1`] | input port 0/1 (read-only: pin levels) | pin levels |
//! | [`OUTPUT_PORT_0`], [`OUTPUT_PORT_1`] | output port 0/1 | `0xFF` |
//! | [`POLARITY_INVERSION_0`], [`POLARITY_INVERSION_1`] | polarity inversion 0/1 | `0x00` |
//! | [`CONFIGURATION_0`], [`CONFIGURATION_1`] | configuration 0/1 (1 = input) | `0xFF` |
//!
//! **Writes.** A write frame is `[command, data…]`. The first data byte goes to the addressed
//! register, the next to the other register of its pair, and so on, alternating (the datasheet's
//! "register pair toggles"). Writes to the input ports are ignored (they are read-only), but
//! still toggle.
//!
//! **Reads.** A read frame returns the register last addressed by a command byte, then the other
//! register of its pair, alternating. Every read frame starts again at the commanded register,
//! as the datasheet says ("the register which was addressed continues to be accessed by reads
//! until a new command byte has been sent").
//!
//! **Driving.** A pin whose configuration bit is 1 is an input and does not drive, whatever its
//! output bit says: the driven outputs are `output & !configuration` ([`Pca9555::driven`]).
//! So at power-up nothing drives although every output bit is 1: the board must be configured
//! before a solenoid can move.
//!
//! **Assumptions** (not in the datasheet, stated here so tests can rely on them):
//! - A pin that is not driven reads 0: the solenoid driver's input pulls it low.
//! - Only the three low bits of the command byte select a register (`command & 7`); the real
//!   chip leaves other command values undefined.
//! - The outputs change when the whole transaction completes (the bus applies a transaction
//!   at its STOP). The real chip latches each port at the ACK of its data byte, at most
//!   9 bit-times apart; the bus log keeps the start and end of each transaction.

/// Command byte of input port 0 (read-only: the levels of pins 0..=7).
pub const INPUT_PORT_0: u8 = 0x00;
/// Command byte of input port 1 (read-only: the levels of pins 8..=15).
pub const INPUT_PORT_1: u8 = 0x01;
/// Command byte of output port 0 (pins 0..=7).
pub const OUTPUT_PORT_0: u8 = 0x02;
/// Command byte of output port 1 (pins 8..=15).
pub const OUTPUT_PORT_1: u8 = 0x03;
/// Command byte of polarity inversion register 0 (1 inverts the input port bit).
pub const POLARITY_INVERSION_0: u8 = 0x04;
/// Command byte of polarity inversion register 1.
pub const POLARITY_INVERSION_1: u8 = 0x05;
/// Command byte of configuration register 0 (1 = input, 0 = output).
pub const CONFIGURATION_0: u8 = 0x06;
/// Command byte of configuration register 1.
pub const CONFIGURATION_1: u8 = 0x07;

/// Output registers at power-up: every bit 1.
pub const POWER_UP_OUTPUT: u8 = 0xFF;
/// Polarity inversion registers at power-up: nothing inverted.
pub const POWER_UP_POLARITY: u8 = 0x00;
/// Configuration registers at power-up: every pin an input (nothing drives).
pub const POWER_UP_CONFIGURATION: u8 = 0xFF;

/// One PCA9555 at a 7-bit I2C address.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Pca9555 {
    address: u8,
    output: [u8; 2],
    polarity: [u8; 2],
    configuration: [u8; 2],
    command: u8,
}

impl Pca9555 {
    /// A chip at the 7-bit `address`, in its power-up state.
    pub const fn new(address: u8) -> Self {
        Self {
            address,
            output: [POWER_UP_OUTPUT; 2],
            polarity: [POWER_UP_POLARITY; 2],
            configuration: [POWER_UP_CONFIGURATION; 2],
            command: INPUT_PORT_0,
        }
    }

    /// Its 7-bit I2C address.
    pub const fn address(&self) -> u8 {
        self.address
    }

    /// Back to the power-up state (a power cycle or a reset pulse).
    pub fn reset(&mut self) {
        *self = Self::new(self.address);
    }

    /// Both output registers: port 0 in bits 0..=7, port 1 in bits 8..=15.
    pub const fn output(&self) -> u16 {
        u16::from_le_bytes(self.output)
    }

    /// Both polarity inversion registers, port 0 low.
    pub const fn polarity(&self) -> u16 {
        u16::from_le_bytes(self.polarity)
    }

    /// Both configuration registers, port 0 low (1 = input, not driving).
    pub const fn configuration(&self) -> u16 {
        u16::from_le_bytes(self.configuration)
    }

    /// The pins driven high: `output & !configuration`. A 1 energises a solenoid.
    pub const fn driven(&self) -> u16 {
        self.output() & !self.configuration()
    }

    /// The level of every pin: a driven pin reads its output bit, an undriven one reads 0
    /// (pulled low by the solenoid driver, see the module notes).
    pub const fn pin_levels(&self) -> u16 {
        self.driven()
    }

    /// The register that the last command byte selected (0..=7).
    pub const fn command(&self) -> u8 {
        self.command
    }

    /// Reads one register without side effects, as a read frame would return it. `register`
    /// is taken modulo 8. Input ports read the pin levels XOR their polarity inversion.
    pub const fn register(&self, register: u8) -> u8 {
        let port = (register & 1) as usize;
        match register & 7 {
            INPUT_PORT_0 | INPUT_PORT_1 => {
                let levels = self.pin_levels().to_le_bytes();
                levels[port] ^ self.polarity[port]
            }
            OUTPUT_PORT_0 | OUTPUT_PORT_1 => self.output[port],
            POLARITY_INVERSION_0 | POLARITY_INVERSION_1 => self.polarity[port],
            _ => self.configuration[port],
        }
    }

    fn set_register(&mut self, register: u8, value: u8) {
        let port = (register & 1) as usize;
        match register & 7 {
            INPUT_PORT_0 | INPUT_PORT_1 => {} // read-only
            OUTPUT_PORT_0 | OUTPUT_PORT_1 => self.output[port] = value,
            POLARITY_INVERSION_0 | POLARITY_INVERSION_1 => self.polarity[port] = value,
            _ => self.configuration[port] = value,
        }
    }

    /// One write frame as the bus delivers it (the bytes after the address byte): the command
    /// byte, then data bytes alternating between the commanded register and its pair. An empty
    /// frame (an address probe) changes nothing.
    pub fn write_frame(&mut self, bytes: &[u8]) {
        let Some((&command, data)) = bytes.split_first() else {
            return;
        };
        self.command = command & 7;
        let mut register = self.command;
        for &byte in data {
            self.set_register(register, byte);
            register ^= 1;
        }
    }

    /// One read frame: fills `buffer` from the commanded register, alternating with its pair.
    pub fn read_frame(&self, buffer: &mut [u8]) {
        let mut register = self.command;
        for byte in buffer {
            *byte = self.register(register);
            register ^= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_up_outputs_are_high_but_nothing_drives() {
        let chip = Pca9555::new(0x21);
        assert_eq!(chip.output(), 0xFFFF);
        assert_eq!(chip.polarity(), 0x0000);
        assert_eq!(chip.configuration(), 0xFFFF);
        assert_eq!(chip.driven(), 0);
        for r in 0..8 {
            let expected = [0x00, 0x00, 0xFF, 0xFF, 0x00, 0x00, 0xFF, 0xFF][r as usize];
            assert_eq!(chip.register(r), expected, "register {r}");
        }
    }

    #[test]
    fn configuration_bit_one_does_not_drive() {
        let mut chip = Pca9555::new(0x21);
        chip.write_frame(&[OUTPUT_PORT_0, 0xFF, 0xFF]);
        chip.write_frame(&[CONFIGURATION_0, 0xF0, 0x0F]); // pins 0..=3 and 12..=15 outputs
        assert_eq!(chip.driven(), 0xF00F);
    }

    #[test]
    fn multi_byte_write_toggles_within_the_pair() {
        let mut chip = Pca9555::new(0x21);
        chip.write_frame(&[OUTPUT_PORT_1, 0x11, 0x22, 0x33]);
        // 0x03 ← 0x11, 0x02 ← 0x22, 0x03 ← 0x33.
        assert_eq!(chip.register(OUTPUT_PORT_0), 0x22);
        assert_eq!(chip.register(OUTPUT_PORT_1), 0x33);
        // The pair never leaks into the next one.
        assert_eq!(chip.register(POLARITY_INVERSION_0), 0x00);
    }

    #[test]
    fn read_toggles_within_the_pair_and_restarts_at_the_command() {
        let mut chip = Pca9555::new(0x21);
        chip.write_frame(&[CONFIGURATION_0, 0xAB, 0xCD]);
        let mut buf = [0; 5];
        chip.read_frame(&mut buf);
        assert_eq!(buf, [0xAB, 0xCD, 0xAB, 0xCD, 0xAB]);
        chip.write_frame(&[CONFIGURATION_1]);
        let mut buf = [0; 3];
        chip.read_frame(&mut buf);
        assert_eq!(buf, [0xCD, 0xAB, 0xCD]);
        chip.read_frame(&mut buf);
        assert_eq!(buf, [0xCD, 0xAB, 0xCD]);
    }

    #[test]
    fn input_port_reflects_driven_pins_and_polarity() {
        let mut chip = Pca9555::new(0x21);
        chip.write_frame(&[OUTPUT_PORT_0, 0x0F, 0x81]);
        assert_eq!(chip.register(INPUT_PORT_0), 0x00, "inputs: nothing driven");
        chip.write_frame(&[CONFIGURATION_0, 0x00, 0x7F]); // port 1: only pin 15 an output
        assert_eq!(chip.register(INPUT_PORT_0), 0x0F);
        assert_eq!(chip.register(INPUT_PORT_1), 0x80);
        chip.write_frame(&[POLARITY_INVERSION_0, 0xFF, 0x00]);
        assert_eq!(chip.register(INPUT_PORT_0), 0xF0);
    }

    #[test]
    fn input_ports_are_read_only() {
        let mut chip = Pca9555::new(0x21);
        chip.write_frame(&[CONFIGURATION_0, 0, 0]);
        chip.write_frame(&[INPUT_PORT_0, 0xFF, 0xFF]);
        assert_eq!(chip.driven(), 0xFFFF, "output registers untouched");
        chip.write_frame(&[OUTPUT_PORT_0, 0, 0]);
        assert_eq!(chip.register(INPUT_PORT_0), 0);
    }

    #[test]
    fn reset_restores_power_up() {
        let mut chip = Pca9555::new(0x24);
        chip.write_frame(&[CONFIGURATION_0, 0, 0]);
        chip.reset();
        assert_eq!(chip, Pca9555::new(0x24));
    }
}
