//! Guards the RAM budget. The thesis's interpreter ran on an ATmega16: 1 KB of SRAM for
//! everything, stack included. The whole interpreter (decoder, held notes, per-key guard
//! state, frame, configuration, counters) must stay within 800 bytes as measured on this
//! 64-bit host (AVR has no padding, so it is a few bytes smaller there), leaving the rest of
//! the 1 KB for the stack and the UART/I2C drivers. If this fails, something grew: find the
//! bytes before raising the figure.

use orch_core::{Decoder, FingerFrame, Interpreter, NotePool};

#[test]
fn the_interpreter_fits_the_atmega16_ram_budget() {
    let size = core::mem::size_of::<Interpreter>();
    assert!(size <= 800, "Interpreter is {size} bytes, budget 800");
}

#[test]
fn the_small_mcu_variant_is_smaller_still() {
    let size = core::mem::size_of::<Interpreter<4, 61, NotePool<32>>>();
    assert!(
        size <= 640,
        "Interpreter<4, 61, NotePool<32>> is {size} bytes"
    );
}

#[test]
fn the_decoder_and_frame_are_small() {
    assert!(core::mem::size_of::<Decoder>() <= 32);
    assert_eq!(core::mem::size_of::<FingerFrame<4>>(), 16);
}
