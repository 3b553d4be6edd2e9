//! The score played on the robot and recorded at once (the `mic` feature): `orch calibrate
//! --out OUT --mic DEVICE`.
//!
//! [`take`] opens nothing itself but the robot's output: the microphone comes opened (so a
//! wrong device is refused before the robot moves), and so does the [`Keep`] file the
//! recording is also written to, if any; the robot's output is opened through orch-stage as
//! `orch play --out` opens it, then
//!
//! 1. the recording starts ([`Mic::start`]) for the score's length, [`TAIL`] and
//!    [`START_MARGIN`];
//! 2. the score plays on orch-stage's live [`Session`], the one `orch play` uses, **without
//!    latency compensation** and at its written tempo: each note is sent at its score time,
//!    so the delays heard are the robot's;
//! 3. whichever fails first stops the other: a recording that fails (an overrun, a device
//!    that stops or goes away) stops the performance, whose output releases every key on the
//!    way out; an output that fails stops the recording; so does the `stop` flag (a signal);
//! 4. the recording is lined up with the performance: put on the host's timeline if the sound
//!    card's clock ran off it ([`stretch`], by the drift measured over the take,
//!    [`clock_ppm`](crate::mic::clock_ppm)), then what was recorded before the score's time 0
//!    (the session's start, on the same clock as the stream's) is cut off, so the recording's
//!    first sample is the score's time 0 and the analysis's capture offset is the latency of
//!    the chain (output, robot, air, microphone, capture).

use std::fmt;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use orch_io::OutSpec;
use orch_perform::{Control, Played, Setup};
use orch_seq::Song;
use orch_stage::session::{open_lanes, Session, SessionFailure};

use crate::mic::{stretch, Mic, MicError, MicFormat};
use crate::{Recording, Score};

/// Recorded after the score's end (its last strike's ring-down is in the score already): the
/// output's and the microphone's latency.
pub const TAIL: Duration = Duration::from_secs(1);
/// Recorded besides, for the time between the stream's start and the performance's.
pub const START_MARGIN: Duration = Duration::from_millis(500);
/// How often the two are looked at.
const POLL: Duration = Duration::from_millis(20);

/// A performance of the score and its recording.
#[derive(Debug)]
pub struct Take {
    /// The recording from the score's time 0, mono.
    pub recording: Recording,
    /// What the microphone recorded in.
    pub format: MicFormat,
    /// How long the stream ran before the score's time 0 (cut off), ms.
    pub lead_ms: f64,
    /// How far the sound card's clock ran from the host's, ppm (see
    /// [`Captured::clock_ppm`](crate::mic::Captured::clock_ppm)); the recording is corrected
    /// for it.
    pub clock_ppm: Option<f64>,
    /// The robot's performance (its report: notes sent, lateness).
    pub played: Played,
    /// Whether the OS refused real-time priority to the sender.
    pub priority_refused: bool,
}

/// A sound card clock this far off the host's (ppm) is worth a warning: 2.5 ms of drift over
/// a 61-key, 4-level take, corrected by a measurement good to a few ppm over minutes.
pub const CLOCK_WARN_PPM: f64 = 10.0;
/// A message sent this late (ms) is worth a warning: the delays measured may be off by it.
pub const LATE_WARN_MS: f64 = 1.0;

impl Take {
    /// What may have spoiled the take's timing, in words: the OS refused the sender real-time
    /// priority, a message went out more than [`LATE_WARN_MS`] late, the sound card's clock
    /// ran [`CLOCK_WARN_PPM`] or more off the host's (corrected, but a measurement good to a
    /// few ppm).
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.priority_refused {
            w.push(
                "the OS refused real-time priority to the sender: under load its messages may \
                 be late, and the delays measured with them"
                    .to_string(),
            );
        }
        let late_ms = self
            .played
            .lateness_us
            .iter()
            .flatten()
            .max()
            .map_or(0.0, |&us| us as f64 / 1000.0);
        if late_ms > LATE_WARN_MS {
            w.push(format!(
                "a message went out {late_ms:.1} ms late: the delays measured may be off by as \
                 much"
            ));
        }
        if let Some(ppm) = self.clock_ppm.filter(|p| p.abs() >= CLOCK_WARN_PPM) {
            w.push(format!(
                "the sound card's clock runs {ppm:+.0} ppm off the host's ({:.1} ms over the \
                 take): corrected, to within the measurement's few ppm",
                ppm.abs() * 1e-6 * self.recording.seconds() * 1000.0
            ));
        }
        w
    }
}

/// Why a take failed.
#[derive(Debug)]
pub enum TakeError {
    /// The output cannot be opened or used (bad input, said in words).
    Output(String),
    /// The microphone failed.
    Mic(MicError),
    /// The performance failed (its output), and was stopped with every key released.
    Performance {
        /// The output, as given.
        out: String,
        /// Why.
        why: SessionFailure,
    },
    /// Stopped by the `stop` flag (a signal) before the end.
    Stopped,
    /// The `--keep` file cannot be created (bad input).
    KeepCreate(PathBuf, std::io::Error),
    /// The recording could not be written to the `--keep` file.
    KeepWrite(PathBuf, hound::Error),
    /// A bug: the score's own SMF did not parse.
    Internal(String),
}

impl fmt::Display for TakeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Output(m) => f.write_str(m),
            Self::Mic(e) => write!(f, "{e} (the performance was stopped, every key released)"),
            Self::Performance { out, why } => write!(
                f,
                "--out {out}: {why} (the recording was stopped; every key released)"
            ),
            Self::Stopped => {
                f.write_str("stopped before the end of the score (every key released)")
            }
            Self::KeepCreate(path, e) => write!(f, "--keep {}: {e}", path.display()),
            Self::KeepWrite(path, _) => write!(f, "--keep {}", path.display()),
            Self::Internal(m) => write!(f, "internal error: {m}"),
        }
    }
}

impl std::error::Error for TakeError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Mic(e) => Some(e),
            Self::KeepWrite(_, e) => Some(e),
            _ => None,
        }
    }
}

impl TakeError {
    /// Whether the error is the user's input (an output that cannot be used as given, a
    /// `--keep` file that cannot be created).
    pub fn is_bad_input(&self) -> bool {
        matches!(self, Self::Output(_) | Self::KeepCreate(..))
    }
}

/// The robot's output for a take, parsed from `text` as `orch play --out` takes it (bad
/// input, [`TakeError::Output`], if it is not one).
pub fn output(text: &str) -> Result<OutSpec, TakeError> {
    OutSpec::parse(text).map_err(|e| TakeError::Output(e.to_string()))
}

/// A file the recording is also written to (`--keep`): created before the take, so that a
/// path that cannot be written does not lose it.
#[derive(Debug)]
pub struct Keep {
    path: PathBuf,
    file: File,
}

impl Keep {
    /// Creates the file at `path` ([`TakeError::KeepCreate`] if it cannot be).
    pub fn create(path: &Path) -> Result<Keep, TakeError> {
        let file = File::create(path).map_err(|e| TakeError::KeepCreate(path.to_path_buf(), e))?;
        Ok(Keep {
            path: path.to_path_buf(),
            file,
        })
    }

    /// Writes `recording` to the file (WAV, 32-bit float).
    pub fn write(self, recording: &Recording) -> Result<(), TakeError> {
        recording
            .write(BufWriter::new(self.file))
            .map_err(|e| TakeError::KeepWrite(self.path, e))
    }
}

/// How the robot plays the score: as `orch play --no-compensation` sets it up (only the
/// presses kept of the virtual robot's account), at the written tempo.
pub fn setup(robot: &orch_robot::Robot) -> Setup {
    Setup::for_robot(robot).with_compensation(false)
}

/// Plays `score` on the robot at `out` and records it from `mic` at once (see the
/// [module notes](self)). `stop` (set by a signal) ends both, every key released.
pub fn take(
    robot: &orch_robot::Robot,
    score: &Score,
    out: OutSpec,
    mic: Mic,
    stop: &AtomicBool,
) -> Result<Take, TakeError> {
    if !out.channels.contains(0) {
        return Err(TakeError::Output(format!(
            "--out {}: the calibration score is on channel 1, which this output does not take",
            out.text
        )));
    }
    let song = Song::parse(&score.to_smf()).map_err(|e| TakeError::Internal(e.to_string()))?;
    let out_text = out.text.clone();
    let lanes = open_lanes(vec![out], &setup(robot)).map_err(|e| match e {
        orch_stage::LiveError::BadInput(m) => TakeError::Output(m),
        e => TakeError::Output(format!("--out {out_text}: {e}")),
    })?;
    let seconds = f64::from(score.length_ms()) / 1000.0 + (TAIL + START_MARGIN).as_secs_f64();
    let capture = mic.start(seconds).map_err(TakeError::Mic)?;
    let format = capture.format();
    let control = Control::new();
    let origin = Instant::now();
    let session = Session::start(song, lanes, Arc::clone(&control), origin);
    let mut stopped = false;
    while !session.is_finished() {
        if stop.load(Ordering::SeqCst) {
            stopped = true;
        }
        if stopped || capture.has_failed() {
            control.stop();
        }
        std::thread::sleep(POLL);
    }
    // Every key is up once the session has finished (its outputs release them on the way out).
    let finished = session.finish();
    let mic_failed = capture.has_failed();
    if let Some((spec, why)) = finished.failed.filter(|_| !mic_failed) {
        capture.stop();
        let _ = capture.finish();
        return Err(TakeError::Performance {
            out: spec.text,
            why,
        });
    }
    if stopped && !mic_failed {
        capture.stop();
        let _ = capture.finish();
        return Err(TakeError::Stopped);
    }
    // The recording's tail (or its error: a stalled one has not finished).
    while !capture.is_finished() && !capture.has_failed() {
        if stop.load(Ordering::SeqCst) {
            capture.stop();
            let _ = capture.finish();
            return Err(TakeError::Stopped);
        }
        std::thread::sleep(POLL);
    }
    let captured = capture.finish().map_err(TakeError::Mic)?;
    let ended = finished
        .ended
        .into_iter()
        .next()
        .ok_or_else(|| TakeError::Internal("the session ended without its robot".into()))?;
    // The score's time 0 on the performance's clock, and the stream's start on the same.
    let score_zero = origin + Duration::from_micros(ended.played.start_us);
    let lead = score_zero.saturating_duration_since(captured.started);
    let rate = captured.recording.rate;
    let cut = (lead.as_secs_f64() * f64::from(rate)).round() as usize;
    let mut samples = captured.recording.samples;
    if let Some(ppm) = captured.clock_ppm {
        // On the host's timeline, which the performance kept.
        samples = stretch(&samples, 1.0 + ppm * 1e-6);
    }
    let recording = Recording::from_samples(rate, samples[cut.min(samples.len())..].to_vec());
    Ok(Take {
        recording,
        format,
        lead_ms: lead.as_secs_f64() * 1000.0,
        clock_ppm: captured.clock_ppm,
        played: ended.played,
        priority_refused: finished.priority_refused,
    })
}
