//! WAV files: stereo, 32-bit float samples (no rounding to integers, nothing clipped by the
//! format: a sample past full scale is kept, and counted in [`Rendered::over`]).
//!
//! [`Rendered::over`]: crate::Rendered::over

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::RenderError;

/// A WAV file being written.
pub struct WavOut {
    writer: hound::WavWriter<BufWriter<File>>,
    path: PathBuf,
}

impl WavOut {
    /// Creates `path` for stereo 32-bit float samples at `sample_rate` Hz.
    pub fn create(path: &Path, sample_rate: u32) -> Result<Self, RenderError> {
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let writer = hound::WavWriter::create(path, spec).map_err(|source| RenderError::Wav {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(Self {
            writer,
            path: path.to_path_buf(),
        })
    }

    /// Appends samples, `left` and `right` of the same length.
    pub fn write(&mut self, left: &[f32], right: &[f32]) -> Result<(), RenderError> {
        for (&l, &r) in left.iter().zip(right) {
            self.writer
                .write_sample(l)
                .and_then(|()| self.writer.write_sample(r))
                .map_err(|source| RenderError::Wav {
                    path: self.path.clone(),
                    source,
                })?;
        }
        Ok(())
    }

    /// Writes the header's lengths and closes the file.
    pub fn finish(self) -> Result<(), RenderError> {
        let path = self.path;
        self.writer
            .finalize()
            .map_err(|source| RenderError::Wav { path, source })
    }
}

/// Reads a stereo (or mono: both channels the same) float or integer WAV file into its two
/// channels, scaled to ±1.0, and its sample rate. For checking renders.
pub fn read(path: &Path) -> Result<(Vec<f32>, Vec<f32>, u32), RenderError> {
    let wav_err = |source| RenderError::Wav {
        path: path.to_path_buf(),
        source,
    };
    let mut reader = hound::WavReader::open(path).map_err(wav_err)?;
    let spec = reader.spec();
    let samples: Vec<f32> = match spec.sample_format {
        hound::SampleFormat::Float => reader
            .samples::<f32>()
            .collect::<Result<_, _>>()
            .map_err(wav_err)?,
        hound::SampleFormat::Int => {
            let scale = (1u64 << (spec.bits_per_sample - 1)) as f32;
            reader
                .samples::<i32>()
                .map(|s| s.map(|v| v as f32 / scale))
                .collect::<Result<_, _>>()
                .map_err(wav_err)?
        }
    };
    let ch = usize::from(spec.channels.max(1));
    let left: Vec<f32> = samples.iter().step_by(ch).copied().collect();
    let right: Vec<f32> = if ch > 1 {
        samples.iter().skip(1).step_by(ch).copied().collect()
    } else {
        left.clone()
    };
    Ok((left, right, spec.sample_rate))
}
