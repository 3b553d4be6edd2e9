//! A crate's example run as its user runs it (`cargo run -p CRATE --example NAME`), for the
//! test that keeps it working: it must succeed, and its standard output is given back.

use std::process::Command;

/// Runs `cargo run -q -p package --example name -- args` from the workspace and returns its
/// standard output; panics, saying what it printed, if it fails.
pub fn run(package: &str, name: &str, args: &[&str]) -> String {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["run", "-q", "-p", package, "--example", name, "--"])
        .args(args)
        .output()
        .expect("cargo runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{package}'s example {name} failed ({}):\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}
