//! Standard MIDI Files built by the tests: one track at 480 ticks a quarter from its events
//! ([`one_track`], [`at_ticks`]) or its bytes ([`wrap_track`]), any format and division
//! ([`smf`]), and the quarter notes many tests play ([`quarters_smf`]).

/// `value` as a variable-length quantity (7 bits a byte, most significant first).
pub fn vlq(mut value: u32) -> Vec<u8> {
    let mut out = vec![(value & 0x7F) as u8];
    value >>= 7;
    while value > 0 {
        out.insert(0, 0x80 | (value & 0x7F) as u8);
        value >>= 7;
    }
    out
}

/// A track's bytes from `(delta ticks, event bytes)`, with its End of Track.
pub fn track(events: &[(u32, &[u8])]) -> Vec<u8> {
    let mut data = Vec::new();
    for (delta, bytes) in events {
        data.extend(vlq(*delta));
        data.extend_from_slice(bytes);
    }
    data.extend([0x00, 0xFF, 0x2F, 0x00]);
    data
}

/// A format 0 file, 480 ticks a quarter, whose one track is `data` (delta-timed events, its
/// End of Track included).
pub fn wrap_track(data: &[u8]) -> Vec<u8> {
    let mut f = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
    f.extend_from_slice(&(data.len() as u32).to_be_bytes());
    f.extend_from_slice(data);
    f
}

/// A format 0 file, 480 ticks a quarter, of `(delta ticks, event bytes)`.
pub fn one_track(events: &[(u32, &[u8])]) -> Vec<u8> {
    wrap_track(&track(events))
}

/// A format 0 file, 480 ticks a quarter, of `(tick, event bytes)` at absolute ticks, in any
/// order (sorted by tick, stably).
pub fn at_ticks(events: &[(u64, Vec<u8>)]) -> Vec<u8> {
    let mut sorted: Vec<&(u64, Vec<u8>)> = events.iter().collect();
    sorted.sort_by_key(|(t, _)| *t);
    let mut last = 0;
    let deltas: Vec<(u32, &[u8])> = sorted
        .into_iter()
        .map(|(t, bytes)| {
            let d = (t - last) as u32;
            last = *t;
            (d, bytes.as_slice())
        })
        .collect();
    one_track(&deltas)
}

/// A file of `format` with the raw 16-bit `division` and tracks of `(delta, event bytes)`,
/// each given its End of Track.
pub fn smf(format: u16, division: u16, tracks: &[Vec<(u32, Vec<u8>)>]) -> Vec<u8> {
    let mut out = b"MThd".to_vec();
    out.extend_from_slice(&6u32.to_be_bytes());
    out.extend_from_slice(&format.to_be_bytes());
    out.extend_from_slice(&(tracks.len() as u16).to_be_bytes());
    out.extend_from_slice(&division.to_be_bytes());
    for t in tracks {
        let events: Vec<(u32, &[u8])> = t.iter().map(|(d, e)| (*d, e.as_slice())).collect();
        let data = track(&events);
        out.extend_from_slice(b"MTrk");
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        out.extend(data);
    }
    out
}

/// A Set Tempo meta event's bytes.
pub fn tempo(us_per_quarter: u32) -> Vec<u8> {
    let mut e = vec![0xFF, 0x51, 0x03];
    e.extend_from_slice(&us_per_quarter.to_be_bytes()[1..]);
    e
}

/// A one-track file: `beats` quarter notes at `bpm` (480 ticks a quarter), one note each
/// (48, 49, … 71, then again), half a beat long.
pub fn quarters_smf(beats: u32, bpm: f64) -> Vec<u8> {
    let mut trk = vec![0x00];
    trk.extend(tempo((60e6 / bpm).round() as u32));
    for i in 0..beats {
        let n = 48 + (i % 24) as u8;
        let delta: &[u8] = if i == 0 { &[0x00] } else { &[0x81, 0x70] };
        trk.extend_from_slice(delta);
        trk.extend_from_slice(&[0x90, n, 100, 0x81, 0x70, 0x80, n, 0]);
    }
    trk.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
    wrap_track(&trk)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vlq_is_seven_bits_a_byte_most_significant_first() {
        assert_eq!(vlq(0), [0x00]);
        assert_eq!(vlq(0x7F), [0x7F]);
        assert_eq!(vlq(0x80), [0x81, 0x00]);
        assert_eq!(vlq(9600), [0xCB, 0x00]);
    }

    #[test]
    fn at_ticks_sorts_and_takes_deltas() {
        let f = at_ticks(&[(480, vec![0x80, 60, 0]), (0, vec![0x90, 60, 100])]);
        let data = &f[22..];
        assert_eq!(
            data,
            [0x00, 0x90, 60, 100, 0x83, 0x60, 0x80, 60, 0, 0x00, 0xFF, 0x2F, 0x00]
        );
        assert_eq!(
            f,
            one_track(&[(0, &[0x90, 60, 100]), (480, &[0x80, 60, 0])])
        );
    }
}
