//! The teaching example runs as its header says, and reads what it says.

#[test]
fn read_file_tells_the_song_and_its_first_notes() {
    let out = testkit::examples::run("orch-seq", "read_file", &[]);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines[0], "Parallel, 114 notes, 34.3 s, 112 bpm at the start",
        "{out}"
    );
    assert_eq!(
        lines[1], " 0.000 s  bar 1 beat 1  channel 1 note 64 velocity 90",
        "{out}"
    );
    assert_eq!(
        lines[6], " 0.536 s  bar 1 beat 2  channel 1 note 64 velocity 90",
        "{out}"
    );
}
