//! Guards the RAM budget. The thesis's interpreter ran on an ATmega16: 1 KB of SRAM for
//! everything, stack included. The MCU build of the interpreter (`NotePool<32>` for the held
//! notes: decoder, held notes, per-key guard state and timed-key mask, frame, configuration)
//! must stay within 616 bytes without the `duty-limit` and `stats` features, 544 with the
//! configuration a constant ([`Thesis`], as the ATmega16 firmware builds it), measured on this 64-bit host (AVR has no padding, so it is a few bytes
//! smaller there), leaving the rest of the 1 KB for the stack and the UART/I2C drivers; the
//! duty limit adds 2 bytes a key, the statistics and the decoder's counters 88 bytes (and
//! padding), dynamics 900 (128 with a constant configuration), strike groups 3260 (20 with a
//! constant configuration), the fingered group 252 (40). The host's default (`NoteTable`, exact under any load, duty limit and statistics
//! on) is allowed 1232. If a figure fails, something grew: find the bytes before raising it, and
//! update the crate docs' table.

use orch_core::{Decoder, FingerFrame, Interpreter, NotePool, Thesis};

#[test]
fn the_mcu_interpreter_fits_the_atmega16_ram_budget() {
    let size = core::mem::size_of::<Interpreter<4, 61, NotePool<32>>>();
    let mut budget = 616;
    if cfg!(feature = "duty-limit") {
        budget += 128;
    }
    if cfg!(feature = "stats") {
        budget += 88;
    }
    if cfg!(feature = "dynamics") {
        // The configuration's per-key touch table (768) and strike time, the duties last
        // written (128).
        budget += 900;
    }
    if cfg!(feature = "strike") {
        // The configuration's strike groups: every key's pulse (1536), the sparse groups'
        // note maps (512) and leads (512), the lead times (512), the dampers (128), the
        // groups; the dampers due (16), the skipped count.
        budget += 3260;
    }
    if cfg!(feature = "wind") {
        // The fingered group's configuration (its table of 48 fingerings, 192) and state
        // (the notes held, their order, the note playing and its phase), the count of notes
        // dropped as monophonic.
        budget += 252;
    }
    assert!(
        size <= budget,
        "Interpreter<4, 61, NotePool<32>> is {size} bytes, budget {budget}"
    );
}

/// The ATmega16's own build: the thesis's configuration as a constant ([`Thesis`]) takes no
/// RAM (the configuration's 64 bytes and their padding go).
#[test]
fn the_fixed_thesis_interpreter_is_smaller_still() {
    let size = core::mem::size_of::<Interpreter<4, 61, NotePool<32>, Thesis>>();
    let mut budget = 544;
    if cfg!(feature = "duty-limit") {
        budget += 120;
    }
    if cfg!(feature = "stats") {
        budget += 96;
    }
    if cfg!(feature = "dynamics") {
        // The duties last written (the configuration is a constant).
        budget += 128;
    }
    if cfg!(feature = "strike") {
        // The dampers due (16) and the skipped count.
        budget += 20;
    }
    if cfg!(feature = "wind") {
        // The fingered group's state and the monophonic count.
        budget += 40;
    }
    assert!(
        size <= budget,
        "Interpreter<4, 61, NotePool<32>, Thesis> is {size} bytes, budget {budget}"
    );
}

#[test]
fn the_host_interpreter_keeps_its_stated_size() {
    let size = core::mem::size_of::<Interpreter>();
    let mut stated = 1024;
    if cfg!(feature = "duty-limit") {
        stated += 120;
    }
    if cfg!(feature = "stats") {
        stated += 96;
    }
    if cfg!(feature = "dynamics") {
        stated += 900;
    }
    if cfg!(feature = "strike") {
        stated += 3260;
    }
    if cfg!(feature = "wind") {
        stated += 252;
    }
    assert!(
        size <= stated,
        "Interpreter is {size} bytes, stated {stated}"
    );
}

#[test]
fn the_decoder_and_frame_are_small() {
    let decoder = if cfg!(feature = "stats") { 28 } else { 12 };
    assert!(core::mem::size_of::<Decoder>() <= decoder);
    // Outputs and what was written, 2 bytes a board each, and the touched boards' mask.
    assert_eq!(core::mem::size_of::<FingerFrame<4>>(), 18);
}
