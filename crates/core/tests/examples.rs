//! The teaching example runs as its header says, and shows what it says.

#[test]
fn own_board_presses_and_the_guard_lifts_a_lost_note_off() {
    let out = testkit::examples::run("orch-core", "own_board", &[]);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines,
        [
            "     0.0 ms  board 0x22 <- 0000000100000000",
            "     0.6 ms  board 0x22 <- 0001000100000000",
            "   500.0 ms  board 0x22 <- 0001000000000000",
            "  4500.0 ms  board 0x22 <- 0000000000000000",
        ],
        "{out}"
    );
}
