//! Helpers shared by the integration tests: the corpus, and hand-built SMF bytes.
#![allow(dead_code, unused_imports)]

use std::path::PathBuf;

/// The shared corpus of real MIDI files, beside the checkout.
pub fn corpus_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    assert!(
        dir.join("MANIFEST.tsv").is_file(),
        "the MIDI corpus is missing: expected {}/MANIFEST.tsv (CI keeps ../shared/midi beside the checkout)",
        dir.display()
    );
    dir
}

/// One MANIFEST.tsv row.
#[derive(Debug, Clone)]
pub struct Row {
    pub file: String,
    pub note_ons: Option<usize>,
    pub seconds: Option<f64>,
    pub mido_ok: bool,
}

pub fn manifest() -> Vec<Row> {
    let text = std::fs::read_to_string(corpus_dir().join("MANIFEST.tsv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split('\t').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("MANIFEST.tsv has no column {name}"))
    };
    let (file, notes, seconds, mido) = (col("file"), col("note_ons"), col("seconds"), col("mido"));
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let get = |i: usize| f.get(i).copied().unwrap_or("");
            Row {
                file: get(file).to_string(),
                note_ons: get(notes).parse().ok(),
                seconds: get(seconds).parse().ok(),
                mido_ok: get(mido) == "ok",
            }
        })
        .collect()
}

pub fn read(file: &str) -> Vec<u8> {
    std::fs::read(corpus_dir().join(file)).unwrap()
}

pub use testkit::smf::{smf, vlq};

pub use testkit::smf::tempo;

pub fn on(ch: u8, note: u8) -> Vec<u8> {
    vec![0x90 | ch, note, 100]
}

pub fn off(ch: u8, note: u8) -> Vec<u8> {
    vec![0x80 | ch, note, 0]
}
