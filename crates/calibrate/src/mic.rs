//! Live capture from a microphone: an ALSA capture PCM opened by name, recorded into memory
//! (the `mic` feature).
//!
//! - **The device** ([`Mic::open`]): any ALSA PCM name: `default`, `hw:1,0`, `plughw:CARD=Mic`,
//!   or a definition of one's own in `~/.asoundrc` (`arecord -L` lists most). It is opened
//!   non-blocking, so a read does not wait on a device that has stopped (and one that waits
//!   all the same, inside a plugin, is caught by the stall watch below).
//! - **The format** (negotiated at open, [`MicFormat`]): interleaved, the first sample format the
//!   device takes of 32-bit, 24-bit packed (3 bytes) and 16-bit signed integer and 32-bit
//!   float, all little-endian; 48 kHz, else 44.1 kHz, else the device's rate nearest 48 kHz
//!   within [`MIN_RATE`]..=[`MAX_RATE`], without ALSA's resampler; one channel, else the
//!   fewest the device has, of which the first is kept.
//! - **The recording** ([`Mic::start`]): a thread reads a set number of frames, a period at a
//!   time, into memory. [`Capturing::started`] is when the stream started (taken around
//!   `snd_pcm_start`, on the same monotonic clock as [`Instant`]): the recording's first
//!   sample, to line it up with a performance started after it. The device's clock is
//!   measured against that one over the recording ([`clock_ppm`]), for [`stretch`] to put the
//!   recording back on the host's timeline.
//! - **Errors** ([`MicError`]): a device that does not exist, is busy, or takes none of the
//!   formats; while recording, an overrun (samples lost: the timing after it would be wrong,
//!   so the recording is refused rather than patched), a device that delivers nothing for
//!   [`STALL`] (watched from outside the capture thread, so a read stuck inside alsa-lib is
//!   caught too), or a read that fails (a USB microphone unplugged). Stopping it
//!   ([`Capturing::stop`]) ends it with what it has.

use std::ffi::CString;
use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use alsa::pcm::{Access, Format, HwParams, PCM};
use alsa::{Direction, ValueOr};

pub use crate::wav::{MAX_RATE, MIN_RATE};
use crate::Recording;

/// A device that delivers no samples for this long while recording has stopped: the recording
/// ends with [`MicError::Stalled`].
pub const STALL: Duration = Duration::from_secs(2);
/// The capture buffer asked for: room for this much sound between two reads, µs.
const BUFFER_US: u32 = 1_000_000;
/// One read, µs.
const PERIOD_US: u32 = 50_000;
/// How long one wait for samples lasts before the stop flag and the stall are looked at, ms.
const WAIT_MS: u32 = 100;

/// A sample format the capture reads (all little-endian, interleaved).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleFormat {
    /// 32-bit signed integer (`S32_LE`): a 24-bit converter's samples in full.
    S32,
    /// 24-bit signed integer in 3 bytes (`S24_3LE`): many USB interfaces' only format.
    S24Packed,
    /// 32-bit float (`FLOAT_LE`).
    F32,
    /// 16-bit signed integer (`S16_LE`).
    S16,
}

impl SampleFormat {
    /// Every format, in the order they are asked for.
    pub const PREFERRED: [SampleFormat; 4] = [Self::S32, Self::S24Packed, Self::F32, Self::S16];

    /// Bytes a sample.
    pub fn bytes(self) -> usize {
        match self {
            Self::S32 | Self::F32 => 4,
            Self::S24Packed => 3,
            Self::S16 => 2,
        }
    }

    /// ALSA's name for it.
    pub fn name(self) -> &'static str {
        match self {
            Self::S32 => "S32_LE",
            Self::S24Packed => "S24_3LE",
            Self::F32 => "FLOAT_LE",
            Self::S16 => "S16_LE",
        }
    }

    fn alsa(self) -> Format {
        match self {
            Self::S32 => Format::S32LE,
            Self::S24Packed => Format::S243LE,
            Self::F32 => Format::FloatLE,
            Self::S16 => Format::S16LE,
        }
    }

    /// One sample's value in -1.0..=1.0 from its bytes (`b.len()` is [`bytes`](Self::bytes)).
    pub fn value(self, b: &[u8]) -> f32 {
        match self {
            Self::S32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32 / 2_147_483_648.0,
            Self::S24Packed => {
                // Into the top three bytes of an i32: the sign comes along.
                (i32::from_le_bytes([0, b[0], b[1], b[2]]) >> 8) as f32 / 8_388_608.0
            }
            Self::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            Self::S16 => f32::from(i16::from_le_bytes([b[0], b[1]])) / 32_768.0,
        }
    }
}

impl fmt::Display for SampleFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What the device and the capture agreed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MicFormat {
    /// The sample format.
    pub format: SampleFormat,
    /// Samples a second.
    pub rate: u32,
    /// Channels a frame (the first is kept).
    pub channels: u32,
}

impl MicFormat {
    /// Bytes a frame.
    pub fn frame_bytes(&self) -> usize {
        self.format.bytes() * self.channels as usize
    }

    /// The first channel of interleaved frames, as samples in -1.0..=1.0 (a partial frame at
    /// the end is left out).
    pub fn first_channel<'a>(&self, frames: &'a [u8]) -> impl Iterator<Item = f32> + 'a {
        let format = self.format;
        frames
            .chunks_exact(self.frame_bytes())
            .map(move |f| format.value(&f[..format.bytes()]))
    }
}

impl fmt::Display for MicFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}, {} Hz, ", self.format, self.rate)?;
        if self.channels == 1 {
            f.write_str("mono")
        } else {
            write!(f, "{} channels (the first kept)", self.channels)
        }
    }
}

/// Why a microphone cannot be opened or recorded from.
#[derive(Debug)]
pub enum MicError {
    /// No capture device of that name (`arecord -L` lists them).
    NoDevice {
        /// The name given.
        device: String,
        /// ALSA's reason.
        why: String,
    },
    /// The device is in use by another program.
    Busy {
        /// The name given.
        device: String,
    },
    /// The device takes none of the formats, rates or channel counts the capture reads.
    Format {
        /// The name given.
        device: String,
        /// What it refused.
        why: String,
    },
    /// Samples were lost: the capture did not read in time.
    Overrun {
        /// The name given.
        device: String,
        /// When, s into the recording.
        at_s: f64,
    },
    /// The device delivered no samples for [`STALL`].
    Stalled {
        /// The name given.
        device: String,
        /// When it stopped, s into the recording.
        at_s: f64,
    },
    /// Reading failed (the device went away, or was suspended).
    Failed {
        /// The name given.
        device: String,
        /// When, s into the recording.
        at_s: f64,
        /// ALSA's reason.
        why: String,
    },
}

impl fmt::Display for MicError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoDevice { device, why } => write!(
                f,
                "--mic {device}: no such capture device ({why}); `arecord -L` lists them \
                 (such as default, or plughw:CARD=NAME,DEV=0)"
            ),
            Self::Busy { device } => write!(
                f,
                "--mic {device}: the device is busy (another program is recording from it)"
            ),
            Self::Format { device, why } => write!(
                f,
                "--mic {device}: the device takes none of the formats orch records (S32_LE, \
                 S24_3LE, FLOAT_LE or S16_LE at {MIN_RATE} to {MAX_RATE} Hz): {why}; try its \
                 plughw: name, which converts"
            ),
            Self::Overrun { device, at_s } => write!(
                f,
                "--mic {device}: samples were lost {at_s:.1} s into the recording (an \
                 overrun: the machine did not read them in time), so the timing after it \
                 would be wrong; record again with less else running"
            ),
            Self::Stalled { device, at_s } => write!(
                f,
                "--mic {device}: the device stopped delivering sound {at_s:.1} s into the \
                 recording (nothing for {} s)",
                STALL.as_secs()
            ),
            Self::Failed { device, at_s, why } => write!(
                f,
                "--mic {device}: reading failed {at_s:.1} s into the recording: {why}"
            ),
        }
    }
}

impl std::error::Error for MicError {}

impl MicError {
    /// Whether the error is the user's (a device that cannot be used as given), not one that
    /// happened while recording.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Self::NoDevice { .. } | Self::Busy { .. } | Self::Format { .. }
        )
    }
}

/// A capture device, opened and set up, not yet recording.
pub struct Mic {
    pcm: PCM,
    device: String,
    format: MicFormat,
}

impl fmt::Debug for Mic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Mic")
            .field("device", &self.device)
            .field("format", &self.format)
            .finish()
    }
}

fn errno(e: &alsa::Error) -> i32 {
    e.errno().abs()
}

impl Mic {
    /// Opens the ALSA capture PCM `device` and negotiates its format (see the
    /// [module notes](self)).
    pub fn open(device: &str) -> Result<Mic, MicError> {
        let no_device = |why: String| MicError::NoDevice {
            device: device.to_string(),
            why,
        };
        let name = CString::new(device).map_err(|_| no_device("a NUL in the name".into()))?;
        let pcm = PCM::open(&name, Direction::Capture, true).map_err(|e| match errno(&e) {
            libc::EBUSY => MicError::Busy {
                device: device.to_string(),
            },
            _ => no_device(describe(&e)),
        })?;
        let format = negotiate(&pcm).map_err(|why| MicError::Format {
            device: device.to_string(),
            why,
        })?;
        Ok(Mic {
            pcm,
            device: device.to_string(),
            format,
        })
    }

    /// The format agreed on.
    pub fn format(&self) -> MicFormat {
        self.format
    }

    /// The device's name, as given.
    pub fn device(&self) -> &str {
        &self.device
    }

    /// Starts recording `seconds` of sound on a thread of its own; returns once the stream has
    /// started (or failed to).
    pub fn start(self, seconds: f64) -> Result<Capturing, MicError> {
        let frames = (seconds.max(0.0) * f64::from(self.format.rate)).ceil() as usize;
        let stop = Arc::new(AtomicBool::new(false));
        let failed = Arc::new(AtomicBool::new(false));
        let progress = Arc::new(AtomicUsize::new(0));
        let (tx, rx) = mpsc::channel();
        let device = self.device.clone();
        let format = self.format;
        let thread = {
            let (stop, failed, progress) = (
                Arc::clone(&stop),
                Arc::clone(&failed),
                Arc::clone(&progress),
            );
            std::thread::Builder::new()
                .name("orch-mic".into())
                .spawn(move || {
                    let r = self.record(frames, &stop, &progress, tx);
                    if r.is_err() {
                        failed.store(true, Ordering::SeqCst);
                    }
                    r
                })
                .map_err(|e| MicError::Failed {
                    device: device.clone(),
                    at_s: 0.0,
                    why: format!("cannot start the capture thread: {e}"),
                })?
        };
        match rx.recv() {
            Ok(started) => Ok(Capturing {
                started,
                format,
                device,
                stop,
                failed,
                progress,
                seen: Mutex::new((0, Instant::now())),
                thread,
            }),
            // The thread ended before the stream started: its error says why.
            Err(_) => Err(match thread.join() {
                Ok(Err(e)) => e,
                _ => MicError::Failed {
                    device,
                    at_s: 0.0,
                    why: "the capture thread ended before the stream started".into(),
                },
            }),
        }
    }

    /// The capture thread: starts the stream, tells when, reads `frames` frames (or until
    /// `stop`), counting them in `progress`.
    fn record(
        self,
        frames: usize,
        stop: &AtomicBool,
        progress: &AtomicUsize,
        started: mpsc::Sender<Instant>,
    ) -> Result<Recorded, MicError> {
        let rate = f64::from(self.format.rate);
        let frame_bytes = self.format.frame_bytes();
        let mut samples: Vec<f32> = Vec::with_capacity(frames);
        let at = |n: usize| n as f64 / rate;
        let failed = |n: usize, e: &alsa::Error| MicError::Failed {
            device: self.device.clone(),
            at_s: at(n),
            why: describe(e),
        };
        let overrun = |n: usize| MicError::Overrun {
            device: self.device.clone(),
            at_s: at(n),
        };
        let before = Instant::now();
        self.pcm.start().map_err(|e| failed(0, &e))?;
        let after = Instant::now();
        // The first frame is captured once the stream runs: between the two instants.
        let _ = started.send(before + (after - before) / 2);
        let period = (rate * f64::from(PERIOD_US) / 1e6).ceil() as usize;
        let mut buf = vec![0u8; period.max(1) * frame_bytes];
        let io = self.pcm.io_bytes();
        while samples.len() < frames && !stop.load(Ordering::SeqCst) {
            let want = (frames - samples.len()).min(period) * frame_bytes;
            match io.readi(&mut buf[..want]) {
                Ok(0) => {}
                Ok(n) => {
                    samples.extend(self.format.first_channel(&buf[..n * frame_bytes]));
                    progress.store(samples.len(), Ordering::SeqCst);
                    continue;
                }
                Err(e) if errno(&e) == libc::EAGAIN => {}
                Err(e) if errno(&e) == libc::EPIPE => return Err(overrun(samples.len())),
                Err(e) => return Err(failed(samples.len(), &e)),
            }
            // Nothing to read: wait for the device (a device whose wait returns at once is not
            // spun on). One that never delivers again is the watcher's to call stalled.
            match self.pcm.wait(Some(WAIT_MS)) {
                Ok(_) => std::thread::sleep(Duration::from_millis(2)),
                Err(e) if errno(&e) == libc::EPIPE => return Err(overrun(samples.len())),
                Err(e) => return Err(failed(samples.len(), &e)),
            }
        }
        // Frames captured by now: those read, and those still in the buffer.
        let waiting = self.pcm.delay().unwrap_or(0).max(0) as usize;
        let ended = Instant::now();
        let _ = self.pcm.drop();
        Ok(Recorded {
            captured_by_end: samples.len() + waiting,
            ended,
            samples,
        })
    }
}

/// ALSA's error in words, without the function's name.
fn describe(e: &alsa::Error) -> String {
    std::io::Error::from_raw_os_error(errno(e)).to_string()
}

/// Sets `pcm` up as the [module notes](self) say.
fn negotiate(pcm: &PCM) -> Result<MicFormat, String> {
    let hw = HwParams::any(pcm).map_err(|e| describe(&e))?;
    hw.set_access(Access::RWInterleaved)
        .map_err(|_| "it cannot be read interleaved".to_string())?;
    let format = SampleFormat::PREFERRED
        .into_iter()
        .find(|f| hw.test_format(f.alsa()).is_ok())
        .ok_or_else(|| {
            format!(
                "its formats are {}",
                all_formats(&hw).unwrap_or_else(|| "unknown".into())
            )
        })?;
    hw.set_format(format.alsa()).map_err(|e| describe(&e))?;
    let channels = hw
        .set_channels_near(1)
        .map_err(|e| format!("no channel count: {}", describe(&e)))?;
    // The device's own rates only: ALSA's resampler is not what a measurement wants.
    let _ = hw.set_rate_resample(false);
    let rate = if hw.test_rate(48_000).is_ok() {
        hw.set_rate(48_000, ValueOr::Nearest).map(|_| 48_000)
    } else if hw.test_rate(44_100).is_ok() {
        hw.set_rate(44_100, ValueOr::Nearest).map(|_| 44_100)
    } else {
        hw.set_rate_near(48_000, ValueOr::Nearest)
    }
    .map_err(|e| format!("no sample rate: {}", describe(&e)))?;
    if !(MIN_RATE..=MAX_RATE).contains(&rate) {
        return Err(format!("its nearest rate to 48 kHz is {rate} Hz"));
    }
    // A generous buffer: an overrun only if the reader is held up for most of a second.
    let _ = hw.set_buffer_time_near(BUFFER_US, ValueOr::Nearest);
    let _ = hw.set_period_time_near(PERIOD_US, ValueOr::Nearest);
    pcm.hw_params(&hw).map_err(|e| describe(&e))?;
    Ok(MicFormat {
        format,
        rate,
        channels,
    })
}

/// The formats a device offers, by name (for the error that none fits).
fn all_formats(hw: &HwParams) -> Option<String> {
    use alsa::pcm::Format as F;
    let names: Vec<String> = [
        F::S8,
        F::U8,
        F::S16LE,
        F::S16BE,
        F::S24LE,
        F::S24BE,
        F::S32LE,
        F::S32BE,
        F::FloatLE,
        F::Float64LE,
        F::S243LE,
        F::S243BE,
        F::S203LE,
        F::S183LE,
    ]
    .into_iter()
    .filter(|f| hw.test_format(*f).is_ok())
    .map(|f| f.to_string())
    .collect();
    (!names.is_empty()).then(|| names.join(", "))
}

/// A recording under way (see [`Mic::start`]). It is watched from outside its thread: a
/// device that delivers nothing for [`STALL`] is called stalled even if a read is stuck inside
/// alsa-lib (a plugin that blocks in spite of the non-blocking mode), and that thread is then
/// left behind rather than waited for.
#[derive(Debug)]
pub struct Capturing {
    started: Instant,
    format: MicFormat,
    device: String,
    stop: Arc<AtomicBool>,
    failed: Arc<AtomicBool>,
    /// Frames recorded so far (the thread's count).
    progress: Arc<AtomicUsize>,
    /// The count last seen, and when it last changed.
    seen: Mutex<(usize, Instant)>,
    thread: JoinHandle<Result<Recorded, MicError>>,
}

/// How often [`Capturing::finish`] looks at the thread.
const WATCH: Duration = Duration::from_millis(20);

impl Capturing {
    /// When the stream started: the recording's first sample.
    pub fn started(&self) -> Instant {
        self.started
    }

    /// The format recorded.
    pub fn format(&self) -> MicFormat {
        self.format
    }

    /// Asks the recording to end now, with what it has.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Whether the recording has ended (all recorded, stopped, or failed).
    pub fn is_finished(&self) -> bool {
        self.thread.is_finished()
    }

    /// Whether the recording has failed, or stalled (its error comes from
    /// [`finish`](Self::finish)).
    pub fn has_failed(&self) -> bool {
        self.failed.load(Ordering::SeqCst) || self.stalled_at().is_some()
    }

    /// If no frame has come for [`STALL`] while recording: how far the recording got, s.
    fn stalled_at(&self) -> Option<f64> {
        if self.thread.is_finished() {
            return None;
        }
        let now = self.progress.load(Ordering::SeqCst);
        let mut seen = self.seen.lock().unwrap_or_else(|e| e.into_inner());
        if now != seen.0 {
            *seen = (now, Instant::now());
            return None;
        }
        (seen.1.elapsed() >= STALL).then(|| now as f64 / f64::from(self.format.rate))
    }

    /// Waits for the recording to end and gives it; a stalled one is stopped and given up.
    pub fn finish(self) -> Result<Captured, MicError> {
        while !self.thread.is_finished() {
            if let Some(at_s) = self.stalled_at() {
                self.stop();
                return Err(MicError::Stalled {
                    device: self.device,
                    at_s,
                });
            }
            std::thread::sleep(WATCH);
        }
        let r = self
            .thread
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p))?;
        let rate = self.format.rate;
        Ok(Captured {
            started: self.started,
            format: self.format,
            clock_ppm: clock_ppm(r.captured_by_end, rate, r.ended - self.started),
            recording: Recording::from_samples(rate, r.samples),
        })
    }
}

/// What the capture thread gives.
#[derive(Debug)]
struct Recorded {
    samples: Vec<f32>,
    /// Frames the device had captured when the recording ended (read or not).
    captured_by_end: usize,
    /// When it ended.
    ended: Instant,
}

/// How far the device's sample clock runs from the host's, parts per million (positive: fast),
/// from `frames` captured in `wall` at a nominal `rate`; `None` when the stream did not run in
/// real time for at least 10 s (too short to tell, or not a sound card: a file played as a
/// microphone goes as fast as it is read), told by a rate more than 1 % off.
pub fn clock_ppm(frames: usize, rate: u32, wall: Duration) -> Option<f64> {
    let s = wall.as_secs_f64();
    if s < 10.0 || rate == 0 {
        return None;
    }
    let ratio = frames as f64 / f64::from(rate) / s;
    ((ratio - 1.0).abs() <= 0.01).then_some((ratio - 1.0) * 1e6)
}

/// Lobes of the interpolation kernel on each side ([`stretch`]).
const LOBES: usize = 16;
/// Fractional positions tabulated ([`stretch`]): a position is rounded to 1/4096 of a sample
/// (at 48 kHz, 5 ns).
const PHASES: usize = 4096;

/// A recording made by a clock that ran `ratio` times its nominal rate (1 + ppm × 10⁻⁶),
/// put back on the nominal timeline: `y[n] = x(n · ratio)`, band-limited interpolation
/// (a Lanczos kernel of 16 lobes each side, each phase's weights summing to 1). Sample `n` is
/// then `n / rate` after the first on the host's clock.
pub fn stretch(x: &[f32], ratio: f64) -> Vec<f32> {
    let sinc = |v: f64| {
        if v == 0.0 {
            1.0
        } else {
            let p = std::f64::consts::PI * v;
            p.sin() / p
        }
    };
    let table: Vec<[f32; 2 * LOBES]> = (0..PHASES)
        .map(|p| {
            let frac = p as f64 / PHASES as f64;
            let mut w = [0.0f64; 2 * LOBES];
            for (j, wj) in w.iter_mut().enumerate() {
                // Tap j is sample i0 + j + 1 - LOBES, at distance d from the position.
                let d = frac - (j as f64 + 1.0 - LOBES as f64);
                *wj = sinc(d) * sinc(d / LOBES as f64);
            }
            let sum: f64 = w.iter().sum();
            w.map(|v| (v / sum) as f32)
        })
        .collect();
    let out = (x.len() as f64 / ratio).floor() as usize;
    (0..out)
        .map(|n| {
            let t = n as f64 * ratio;
            let mut i0 = t.floor() as usize;
            let mut p = ((t - i0 as f64) * PHASES as f64).round() as usize;
            if p == PHASES {
                (i0, p) = (i0 + 1, 0);
            }
            let w = &table[p];
            let first = (i0 + 1).saturating_sub(LOBES);
            (first..(i0 + 1 + LOBES).min(x.len()))
                .map(|k| x[k] * w[k + LOBES - 1 - i0])
                .sum()
        })
        .collect()
}

/// A finished recording.
#[derive(Clone, Debug)]
pub struct Captured {
    /// When its first sample was captured.
    pub started: Instant,
    /// The format recorded.
    pub format: MicFormat,
    /// The first channel, mono.
    pub recording: Recording,
    /// How far the device's clock ran from the host's over the recording, ppm ([`clock_ppm`]):
    /// a take's timing drifts by this much (20 ppm: 5 ms over a 4-minute take) unless it is
    /// [`stretch`]ed back.
    pub clock_ppm: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_format_reads_to_scale_and_the_first_channel_is_kept() {
        let stereo = |format, left: &[u8], right: &[u8]| {
            let frames: Vec<u8> = [left, right, left, right].concat();
            let f = MicFormat {
                format,
                rate: 48_000,
                channels: 2,
            };
            f.first_channel(&frames).collect::<Vec<_>>()
        };
        assert_eq!(
            stereo(
                SampleFormat::S16,
                &(-16384i16).to_le_bytes(),
                &32767i16.to_le_bytes()
            ),
            [-0.5, -0.5]
        );
        assert_eq!(
            stereo(
                SampleFormat::S32,
                &(1i32 << 30).to_le_bytes(),
                &i32::MIN.to_le_bytes()
            ),
            [0.5, 0.5]
        );
        assert_eq!(
            stereo(
                SampleFormat::F32,
                &0.25f32.to_le_bytes(),
                &1.0f32.to_le_bytes()
            ),
            [0.25, 0.25]
        );
        // -0.25 in 24 bits: -2097152 = 0xE00000, sent low byte first.
        assert_eq!(
            stereo(
                SampleFormat::S24Packed,
                &[0x00, 0x00, 0xE0],
                &[0xFF, 0xFF, 0x7F]
            ),
            [-0.25, -0.25]
        );
        let mono = MicFormat {
            format: SampleFormat::S24Packed,
            rate: 44_100,
            channels: 1,
        };
        let v: Vec<f32> = mono
            .first_channel(&[0x00, 0x00, 0x40, 0xFF, 0xFF])
            .collect();
        assert_eq!(v, [0.5], "a partial frame at the end is left out");
    }

    #[test]
    fn the_clock_is_measured_on_real_time_streams_only() {
        let s = |secs: f64| Duration::from_secs_f64(secs);
        // 48 000 Hz running 20 ppm fast for 100 s.
        let ppm = clock_ppm(4_800_096, 48_000, s(100.0)).unwrap();
        assert!((ppm - 20.0).abs() < 1e-6, "{ppm}");
        let ppm = clock_ppm(4_799_904, 48_000, s(100.0)).unwrap();
        assert!((ppm + 20.0).abs() < 1e-6, "{ppm}");
        assert_eq!(clock_ppm(480_000, 48_000, s(9.9)), None, "too short");
        assert_eq!(
            clock_ppm(4_800_000, 48_000, s(0.5)),
            None,
            "a file, read at once"
        );
        assert_eq!(
            clock_ppm(48_000 * 200, 48_000, s(100.0)),
            None,
            "not real time"
        );
    }

    #[test]
    fn a_fast_clock_is_stretched_back_onto_the_nominal_timeline() {
        let rate = 48_000.0;
        // A card 100 ppm fast: 2 s of 3 kHz and 7 kHz tones (the partials the analysis
        // listens to), sampled at its own, faster, instants.
        let r = 1.0001;
        let tone = |t: f64| {
            (2.0 * std::f64::consts::PI * 3000.0 * t).sin() * 0.5
                + (2.0 * std::f64::consts::PI * 7000.0 * t + 1.0).sin() * 0.3
        };
        let x: Vec<f32> = (0..96_000)
            .map(|k| tone(k as f64 / (rate * r)) as f32)
            .collect();
        let y = stretch(&x, r);
        assert_eq!(y.len(), (96_000.0 / r) as usize);
        let worst = (LOBES..y.len() - LOBES)
            .map(|n| (f64::from(y[n]) - tone(n as f64 / rate)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 5e-4, "{worst}");
        // Unstretched, the last samples are 0.2 ms (10 samples) off: far from the tones.
        let off = (f64::from(x[95_000]) - tone(95_000.0 / rate)).abs();
        assert!(off > 0.1, "{off}");
    }

    #[test]
    fn a_true_clock_is_left_as_it_is() {
        let x: Vec<f32> = (0..1000).map(|k| ((k * 37) % 101) as f32 / 101.0).collect();
        let y = stretch(&x, 1.0);
        assert_eq!(y.len(), x.len());
        assert!(y.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-6));
    }

    #[test]
    fn the_format_names_itself_as_alsa_does() {
        for f in SampleFormat::PREFERRED {
            assert_eq!(f.alsa().to_string(), f.name());
        }
        let f = MicFormat {
            format: SampleFormat::S16,
            rate: 44_100,
            channels: 2,
        };
        assert_eq!(
            f.to_string(),
            "S16_LE, 44100 Hz, 2 channels (the first kept)"
        );
    }
}
