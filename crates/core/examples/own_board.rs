//! The interpreter on your own board: MIDI bytes in, board writes out, time as an argument.
//!
//! orch-core reads no clock and no bus. Your firmware's loop hands it each byte as it arrives
//! with the time, wakes it at its next deadline (the safety guard's: a key held too long, a
//! silent line), and lets it write the finger boards through one trait, `FingerBoards`.
//! Here the boards are `Recording`, the test double that keeps every write; on a board they
//! are `orch_boards::FingerBoardSet` over your I2C bus, or your own `impl FingerBoards`.
//!
//! `cargo run -p orch-core --example own_board`

use orch_core::{Instant, Interpreter, Recording};

fn main() {
    let mut robot = Interpreter::thesis();
    let mut boards = Recording::<16>::new();
    // What arrives on the DIN line, and when (µs): middle C, then E by running status, and
    // C's Note-Off. E's Note-Off is lost: the guard lifts E at its hold limit.
    let input: [(u64, &[u8]); 3] = [
        (0, &[0x90, 60, 100]),
        (640, &[64, 100]),
        (500_000, &[0x80, 60, 0]),
    ];
    for (t, bytes) in input {
        let now = Instant::from_micros(t);
        robot.feed_slice(bytes, now);
        write(&mut robot, &mut boards, now);
    }
    // Nothing more comes: sleep until each deadline, and let the guard act at it.
    while let Some(deadline) = robot.next_deadline() {
        robot.tick(deadline);
        write(&mut robot, &mut boards, deadline);
    }
    assert_eq!(boards.outputs(1), 0, "every key is up in the end");
}

/// Writes what changed to the boards, and shows it: keys 60 and 64 are on board 1 (0x22).
fn write(robot: &mut Interpreter, boards: &mut Recording<16>, now: Instant) {
    if robot.flush(boards).unwrap() > 0 {
        let ms = now.as_micros() as f64 / 1000.0;
        println!("{ms:>8.1} ms  board 0x22 <- {:016b}", boards.outputs(1));
    }
}
