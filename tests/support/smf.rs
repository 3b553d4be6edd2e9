//! The quarter-note Standard MIDI File that the `orch` package's tests and the performer's
//! conductor tests play (`#[path]`-included by `crates/perform/tests/conduct.rs`): no
//! dependencies, so that any test can take it.

/// A one-track Standard MIDI File: `beats` quarter notes at `bpm` (480 ticks a quarter), one
/// note each (48, 49, … 71, then again), half a beat long.
pub fn quarters_smf(beats: u32, bpm: f64) -> Vec<u8> {
    let mut trk = vec![0x00, 0xFF, 0x51, 0x03];
    trk.extend_from_slice(&((60e6 / bpm).round() as u32).to_be_bytes()[1..]);
    for i in 0..beats {
        let n = 48 + (i % 24) as u8;
        let delta: &[u8] = if i == 0 { &[0x00] } else { &[0x81, 0x70] };
        trk.extend_from_slice(delta);
        trk.extend_from_slice(&[0x90, n, 100, 0x81, 0x70, 0x80, n, 0]);
    }
    trk.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
    let mut smf = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
    smf.extend_from_slice(&(trk.len() as u32).to_be_bytes());
    smf.extend_from_slice(&trk);
    smf
}
