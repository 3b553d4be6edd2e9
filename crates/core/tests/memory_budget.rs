//! Guards the RAM budget. The thesis's interpreter ran on an ATmega16: 1 KB of SRAM for
//! everything, stack included. The MCU build of the interpreter (`NotePool<32>` for the held
//! notes: decoder, held notes, per-key guard state, frame, configuration, counters) must stay
//! within 672 bytes without the `duty-limit` feature (as the ATmega16 firmware builds it),
//! measured on this 64-bit host (AVR has no padding, so it is a few bytes smaller there),
//! leaving the rest of the 1 KB for the stack and the UART/I2C drivers; the duty limit adds
//! 2 bytes a key. The host's default (`NoteTable`, exact under any load, duty limit on) is
//! allowed 1208. If a figure fails, something grew: find the bytes before raising it, and
//! update the crate docs' table.

use orch_core::{Decoder, FingerFrame, Interpreter, NotePool};

#[test]
fn the_mcu_interpreter_fits_the_atmega16_ram_budget() {
    let size = core::mem::size_of::<Interpreter<4, 61, NotePool<32>>>();
    let budget = if cfg!(feature = "duty-limit") {
        672 + 128
    } else {
        672
    };
    assert!(
        size <= budget,
        "Interpreter<4, 61, NotePool<32>> is {size} bytes, budget {budget}"
    );
}

#[test]
fn the_host_interpreter_keeps_its_stated_size() {
    let size = core::mem::size_of::<Interpreter>();
    let stated = if cfg!(feature = "duty-limit") {
        1208
    } else {
        1088
    };
    assert!(
        size <= stated,
        "Interpreter is {size} bytes, stated {stated}"
    );
}

#[test]
fn the_decoder_and_frame_are_small() {
    assert!(core::mem::size_of::<Decoder>() <= 32);
    assert_eq!(core::mem::size_of::<FingerFrame<4>>(), 16);
}
