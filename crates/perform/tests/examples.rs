//! The teaching example runs as its header says, and plays what it says.

#[test]
fn to_midi_out_sends_the_song_and_reports() {
    let out = testkit::examples::run("orch-perform", "to_midi_out", &[]);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "   64.0 ms  [90, 40, 5A]", "{out}");
    assert_eq!(lines[2], "   64.0 ms  [34, 3C]", "{out}");
    let last = lines.last().unwrap();
    assert!(last.starts_with("247 messages sent; 114 notes, "), "{out}");
}
