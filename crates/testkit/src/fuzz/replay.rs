//! Shared by the stable-Rust replay tests (`crates/core/tests/fuzz_replay.rs`,
//! `crates/seq/tests/fuzz_replay.rs`, `tests/fuzz_replay.rs`): finds the inputs of a corpus or
//! regressions folder and runs each through a fuzz target's checks, naming the file that fails.

use std::path::{Path, PathBuf};

/// The input files of `dir` (not the `.md` files nor hidden files), sorted. Panics if `dir`
/// does not exist, so a replay cannot pass by finding nothing.
pub fn inputs(dir: &Path) -> Vec<PathBuf> {
    let entries =
        std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{} must exist: {e}", dir.display()));
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.expect("readable directory entry").path())
        .filter(|p| p.is_file())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            !name.starts_with('.') && !name.ends_with(".md")
        })
        .collect();
    files.sort();
    files
}

/// Runs `check` on every file, panicking with the file's name and the check's message.
pub fn replay(files: &[PathBuf], check: fn(&[u8])) {
    for file in files {
        let data = std::fs::read(file).unwrap();
        let outcome = std::panic::catch_unwind(|| check(&data));
        if let Err(e) = outcome {
            let why = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("{} fails the fuzz checks: {why}", file.display());
        }
    }
}
