//! Helpers shared by the integration tests: the corpus, and hand-built SMF bytes.
#![allow(dead_code)]

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

/// A variable-length quantity.
pub fn vlq(mut v: u32) -> Vec<u8> {
    let mut out = vec![(v & 0x7F) as u8];
    v >>= 7;
    while v > 0 {
        out.insert(0, (v & 0x7F) as u8 | 0x80);
        v >>= 7;
    }
    out
}

/// An SMF with `format`, the raw 16-bit `division`, and tracks of `(delta, event bytes)`.
/// Each track gets an End of Track.
pub fn smf(format: u16, division: u16, tracks: &[Vec<(u32, Vec<u8>)>]) -> Vec<u8> {
    let mut out = b"MThd".to_vec();
    out.extend_from_slice(&6u32.to_be_bytes());
    out.extend_from_slice(&format.to_be_bytes());
    out.extend_from_slice(&(tracks.len() as u16).to_be_bytes());
    out.extend_from_slice(&division.to_be_bytes());
    for t in tracks {
        let mut data = Vec::new();
        for (delta, ev) in t {
            data.extend(vlq(*delta));
            data.extend_from_slice(ev);
        }
        data.extend([0x00, 0xFF, 0x2F, 0x00]);
        out.extend_from_slice(b"MTrk");
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        out.extend(data);
    }
    out
}

/// A tempo meta event.
pub fn tempo(us_per_quarter: u32) -> Vec<u8> {
    let b = us_per_quarter.to_be_bytes();
    vec![0xFF, 0x51, 0x03, b[1], b[2], b[3]]
}

pub fn on(ch: u8, note: u8) -> Vec<u8> {
    vec![0x90 | ch, note, 100]
}

pub fn off(ch: u8, note: u8) -> Vec<u8> {
    vec![0x80 | ch, note, 0]
}
