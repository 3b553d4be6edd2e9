//! 7-bit I2C addresses of the PCA9555 / TCA9555: a fixed `0b0100` high nibble (base 0x20)
//! plus the three hardware address pins A2 A1 A0, so 0x20..=0x27 and up to eight on one bus.
//!
//! The thesis's boards sit at 0x21..=0x24 (A2A1A0 = 1..=4); its C code writes them as
//! 0x42..=0x48, the 7-bit address shifted left with the R/W bit. embedded-hal takes the
//! 7-bit form.

/// The address with A2 = A1 = A0 = 0.
pub const BASE_ADDRESS: u8 = 0x20;
/// The highest address (A2 = A1 = A0 = 1).
pub const LAST_ADDRESS: u8 = BASE_ADDRESS + 7;

/// The 7-bit address for the given levels on the address pins (`true` = tied high).
pub const fn address(a2: bool, a1: bool, a0: bool) -> u8 {
    BASE_ADDRESS | ((a2 as u8) << 2) | ((a1 as u8) << 1) | (a0 as u8)
}

/// The 7-bit address for the pins A2A1A0 read as a 3-bit number, or `None` above 7.
pub const fn address_from_pins(a2a1a0: u8) -> Option<u8> {
    if a2a1a0 <= 7 {
        Some(BASE_ADDRESS | a2a1a0)
    } else {
        None
    }
}

/// Whether a 7-bit address is one a PCA9555 / TCA9555 can answer to (0x20..=0x27).
pub const fn is_device_address(address: u8) -> bool {
    address >= BASE_ADDRESS && address <= LAST_ADDRESS
}

/// The 8-bit write form (address << 1, R/W = 0) that the thesis's C code uses, for logs
/// and for comparing with its listings.
pub const fn write_byte_form(address: u8) -> u8 {
    address << 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn address_pins_add_to_base_0x20() {
        assert_eq!(address(false, false, false), 0x20);
        assert_eq!(address(false, false, true), 0x21);
        assert_eq!(address(true, false, false), 0x24);
        assert_eq!(address(true, true, true), 0x27);
        for n in 0..=7 {
            assert_eq!(address_from_pins(n), Some(0x20 + n));
            assert!(is_device_address(0x20 + n));
        }
        assert_eq!(address_from_pins(8), None);
        assert!(!is_device_address(0x1F));
        assert!(!is_device_address(0x28));
    }

    #[test]
    fn thesis_boards_are_0x42_to_0x48_in_write_form() {
        assert_eq!(write_byte_form(0x21), 0x42);
        assert_eq!(write_byte_form(0x24), 0x48);
    }
}
