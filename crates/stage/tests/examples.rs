//! The teaching example runs as its header says: it watches the song bar by bar and prints
//! the report.

#[test]
fn front_end_watches_and_reports() {
    let out = testkit::examples::run("orch-stage", "front_end", &[]);
    assert!(out.contains("bar 16 "), "it watched to the last bar: {out}");
    assert!(out.contains("\nnotes in the file      114\n"), "{out}");
    assert!(out.contains("\nstrikes heard          113\n"), "{out}");
}
