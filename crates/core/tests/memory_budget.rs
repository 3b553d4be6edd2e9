//! Guards the RAM budget. The thesis's interpreter ran on an ATmega16: 1 KB of SRAM for
//! everything, stack included. The MCU build of the interpreter (`NotePool<32>` for the held
//! notes: decoder, held notes, per-key guard state, frame, configuration, counters) must stay
//! within 640 bytes as measured on this 64-bit host (AVR has no padding, so it is a few bytes
//! smaller there), leaving the rest of the 1 KB for the stack and the UART/I2C drivers. The
//! host's default (`NoteTable`, exact under any load) is allowed 1048. If a figure fails,
//! something grew: find the bytes before raising it, and update the crate docs' table.

use orch_core::{Decoder, FingerFrame, Interpreter, NotePool};

#[test]
fn the_mcu_interpreter_fits_the_atmega16_ram_budget() {
    let size = core::mem::size_of::<Interpreter<4, 61, NotePool<32>>>();
    assert!(
        size <= 640,
        "Interpreter<4, 61, NotePool<32>> is {size} bytes, budget 640"
    );
}

#[test]
fn the_host_interpreter_keeps_its_stated_size() {
    let size = core::mem::size_of::<Interpreter>();
    assert!(size <= 1048, "Interpreter is {size} bytes, stated 1048");
}

#[test]
fn the_decoder_and_frame_are_small() {
    assert!(core::mem::size_of::<Decoder>() <= 32);
    assert_eq!(core::mem::size_of::<FingerFrame<4>>(), 16);
}
