//! Finding strikes in rendered audio, to check a render against the virtual robot (not
//! reading them back from the renderer).
//!
//! The method is made for what a dry render of a sparse score gives: notes with silence
//! between them. An **onset** is the first sample whose magnitude (the larger of the two
//! channels) exceeds `threshold` after at least `min_gap` samples at or below it (the start of
//! the audio counts as silence). A dry render's silence is digital silence (exact zeros) once
//! a note's release has died away, and the renderer starts each voice so that its first
//! sample that is not zero is the strike's (see [`crate::synth`]): with `threshold` = 0.0,
//! the onset is the strike's sample. A higher threshold finds a later sample, by how slowly
//! the soundfont's attack rises (up to tens of samples at −100 dBFS on TimGM6mb's pianos).
//! Not a detector for recordings (noise, reverberation, a neighbour still ringing): that is
//! `orch calibrate`'s work, with spectral flux.

/// Onsets in `left`/`right`: see the [module notes](self). Sample indices.
pub fn onsets(left: &[f32], right: &[f32], threshold: f32, min_gap: usize) -> Vec<usize> {
    let mut found = Vec::new();
    let mut quiet = min_gap; // the start counts as silence
    for (i, (l, r)) in left.iter().zip(right).enumerate() {
        if l.abs().max(r.abs()) > threshold {
            if quiet >= min_gap {
                found.push(i);
            }
            quiet = 0;
        } else {
            quiet = quiet.saturating_add(1);
        }
    }
    found
}

/// The root mean square of both channels over the samples `from..to`.
pub fn rms(left: &[f32], right: &[f32], from: usize, to: usize) -> f32 {
    let to = to.min(left.len()).min(right.len());
    if from >= to {
        return 0.0;
    }
    let sum: f64 = left[from..to]
        .iter()
        .chain(&right[from..to])
        .map(|&x| f64::from(x) * f64::from(x))
        .sum();
    (sum / (2 * (to - from)) as f64).sqrt() as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_onset_needs_silence_before_it() {
        let mut x = vec![0.0f32; 100];
        x[10] = 0.5; // after 10 quiet samples (the start counts as quiet)
        x[12] = 0.5; // 1 quiet sample: the same sound
        x[40] = 1e-6; // below the threshold: quiet
        x[60] = -0.2; // after 47 quiet samples
        assert_eq!(onsets(&x, &x, 1e-5, 20), vec![10, 60]);
        assert_eq!(onsets(&x, &x, 1e-5, 48), vec![10]);
    }

    #[test]
    fn rms_of_a_square_wave() {
        let x: Vec<f32> = (0..100)
            .map(|i| if i % 2 == 0 { 0.5 } else { -0.5 })
            .collect();
        assert!((rms(&x, &x, 0, 100) - 0.5).abs() < 1e-6);
        assert_eq!(rms(&x, &x, 50, 50), 0.0);
    }
}
