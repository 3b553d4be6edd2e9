//! `orch play --link`'s arguments, and what a build without the `link` feature says (the test
//! command runs that one on a build without features; tests/link.rs plays with the feature).

use std::process::Command;

fn orch() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orch"))
}

const SONG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/ode-to-joy.mid");

#[cfg(not(feature = "link"))]
#[test]
fn link_without_the_feature_names_it_and_its_licence() {
    let out = orch()
        .args(["play", SONG, "--link", "--no-view"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("without the `link` feature"), "{err}");
    assert!(
        err.contains("--features link") && err.contains("GPL"),
        "{err}"
    );
}

#[test]
fn link_refuses_what_the_session_decides() {
    for args in [
        &["--link", "--fast"][..],
        &["--link", "--from", "2"][..],
        &["--link", "--tempo", "2"][..],
        &["--start"][..],
    ] {
        let out = orch()
            .args(["play", SONG, "--no-view"])
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}
