//! Reading a recording: a WAV file, 16- or 24-bit integer or 32-bit float, mono or more
//! channels (mixed down to mono), 16 to 192 kHz.

use std::io::Read;

use crate::CalibrateError;

/// The lowest sample rate taken: below it the treble keys' partials are lost and a 1 ms
/// timing is 16 samples or fewer.
pub const MIN_RATE: u32 = 16_000;
/// The highest sample rate taken.
pub const MAX_RATE: u32 = 192_000;

/// A recording, mono, samples in -1.0..=1.0.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Samples a second.
    pub rate: u32,
    /// The samples, mixed down to mono (the mean of the channels).
    pub samples: Vec<f32>,
    /// Samples at full scale (before the mix-down), per second of recording: for the
    /// clipping check.
    pub clipped_per_second: Vec<u32>,
}

impl Recording {
    /// A recording from mono samples already in memory (no clipping counted beyond
    /// |x| >= 0.999).
    pub fn from_samples(rate: u32, samples: Vec<f32>) -> Self {
        let clipped_per_second = samples
            .chunks(rate.max(1) as usize)
            .map(|c| c.iter().filter(|x| x.abs() >= CLIP).count() as u32)
            .collect();
        Self {
            rate,
            samples,
            clipped_per_second,
        }
    }

    /// Its length, s.
    pub fn seconds(&self) -> f64 {
        self.samples.len() as f64 / f64::from(self.rate)
    }

    /// Reads a WAV file.
    pub fn read(reader: impl Read) -> Result<Self, CalibrateError> {
        let wav = hound::WavReader::new(reader).map_err(|e| match e {
            hound::Error::Unsupported => {
                CalibrateError::Format("a WAV encoding hound does not read".into())
            }
            e => CalibrateError::NotWav(e.to_string()),
        })?;
        let spec = wav.spec();
        if !(MIN_RATE..=MAX_RATE).contains(&spec.sample_rate) {
            return Err(CalibrateError::Format(format!(
                "a sample rate of {} Hz (record at {MIN_RATE} to {MAX_RATE} Hz, such as \
                 44100 or 48000)",
                spec.sample_rate
            )));
        }
        let channels = usize::from(spec.channels.max(1));
        let scaled: Vec<f32> = match (spec.sample_format, spec.bits_per_sample) {
            (hound::SampleFormat::Int, 16) => {
                collect(wav.into_samples::<i16>(), |x| f32::from(x) / 32768.0)?
            }
            (hound::SampleFormat::Int, 24) => {
                collect(wav.into_samples::<i32>(), |x| x as f32 / 8_388_608.0)?
            }
            (hound::SampleFormat::Float, 32) => collect(wav.into_samples::<f32>(), |x| x)?,
            (format, bits) => {
                return Err(CalibrateError::Format(format!(
                    "{bits}-bit {} samples (record 16- or 24-bit integer or 32-bit float)",
                    match format {
                        hound::SampleFormat::Int => "integer",
                        hound::SampleFormat::Float => "float",
                    }
                )))
            }
        };
        let rate = spec.sample_rate;
        let frames = scaled.len() / channels;
        let mut samples = Vec::with_capacity(frames);
        let mut clipped_per_second = vec![0u32; frames.div_ceil(rate as usize)];
        for (i, frame) in scaled.chunks_exact(channels).enumerate() {
            if frame.iter().any(|x| x.abs() >= CLIP) {
                clipped_per_second[i / rate as usize] += 1;
            }
            samples.push(frame.iter().sum::<f32>() / channels as f32);
        }
        Ok(Self {
            rate,
            samples,
            clipped_per_second,
        })
    }

    /// Writes it as a 32-bit float mono WAV (for tests, examples and listening).
    pub fn write(&self, writer: impl std::io::Write + std::io::Seek) -> Result<(), hound::Error> {
        let spec = hound::WavSpec {
            channels: 1,
            sample_rate: self.rate,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let mut w = hound::WavWriter::new(writer, spec)?;
        for &x in &self.samples {
            w.write_sample(x)?;
        }
        w.finalize()
    }
}

/// A sample at or above this magnitude is at full scale.
const CLIP: f32 = 0.999;

fn collect<S, R: Read>(
    samples: hound::WavIntoSamples<R, S>,
    scale: impl Fn(S) -> f32,
) -> Result<Vec<f32>, CalibrateError>
where
    S: hound::Sample,
{
    samples
        .map(|s| s.map(&scale))
        .collect::<Result<_, _>>()
        .map_err(|e| CalibrateError::NotWav(format!("its samples cannot be read: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wav(
        spec: hound::WavSpec,
        write: impl Fn(&mut hound::WavWriter<&mut std::io::Cursor<Vec<u8>>>),
    ) -> Vec<u8> {
        let mut c = std::io::Cursor::new(Vec::new());
        let mut w = hound::WavWriter::new(&mut c, spec).unwrap();
        write(&mut w);
        w.finalize().unwrap();
        c.into_inner()
    }

    #[test]
    fn stereo_24_bit_is_mixed_down_and_its_clipping_counted() {
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate: 48_000,
            bits_per_sample: 24,
            sample_format: hound::SampleFormat::Int,
        };
        let bytes = wav(spec, |w| {
            for i in 0..48_000 * 2 {
                // Left at half scale, right at full scale in the first second only.
                w.write_sample(4_194_304i32).unwrap();
                w.write_sample(if i < 48_000 { 8_388_607i32 } else { 0 })
                    .unwrap();
            }
        });
        let r = Recording::read(&bytes[..]).unwrap();
        assert_eq!(r.rate, 48_000);
        assert_eq!(r.samples.len(), 96_000);
        assert!((r.samples[0] - 0.75).abs() < 1e-4, "{}", r.samples[0]);
        assert!((r.samples[60_000] - 0.25).abs() < 1e-4);
        assert_eq!(r.clipped_per_second, [48_000, 0]);
    }

    #[test]
    fn sixteen_bit_mono_reads_to_scale() {
        let spec = hound::WavSpec {
            channels: 1,
            sample_rate: 44_100,
            bits_per_sample: 16,
            sample_format: hound::SampleFormat::Int,
        };
        let bytes = wav(spec, |w| {
            w.write_sample(-16384i16).unwrap();
            w.write_sample(16384i16).unwrap();
        });
        let r = Recording::read(&bytes[..]).unwrap();
        assert_eq!(r.samples, [-0.5, 0.5]);
    }
}
