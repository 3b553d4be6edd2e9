//! Single-bit masks without a shift by a variable amount: an 8-bit MCU has no barrel shifter,
//! so `1 << n` is a loop of `n` one-bit shifts there (up to 15 of them, ≈ 60 cycles for a
//! board's output bit on an AVR). These take the same few steps for every `n`.

/// The eight masks of a byte. (Computed instead, `if n & 2 != 0 { m <<= 2 }` and the like, LLVM
/// turns the steps back into shifts by a variable amount.)
const BIT8: [u8; 8] = [1, 2, 4, 8, 16, 32, 64, 128];

/// `1 << (n & 7)`.
#[inline(always)]
pub(crate) const fn bit8(n: u8) -> u8 {
    BIT8[(n & 7) as usize]
}

/// `1 << (n & 15)`.
#[inline(always)]
pub(crate) const fn bit16(n: u8) -> u16 {
    let m = bit8(n);
    // All ones if the bit is in the low byte, else zero: masks, not a choice between two
    // values (which LLVM makes a shift by 0 or 8 again).
    let low = ((n >> 3) & 1).wrapping_sub(1);
    u16::from_le_bytes([m & low, m & !low])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_masks_are_the_shifts_for_every_amount() {
        for n in 0..=255u8 {
            assert_eq!(bit8(n), 1 << (n & 7), "{n}");
            assert_eq!(bit16(n), 1 << (n & 15), "{n}");
        }
    }
}
