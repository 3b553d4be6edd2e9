//! # orch-baton: the tempo recognition unit, in software
//!
//! The thesis's robot orchestra followed a conductor: a camera watched a baton with a red LED
//! at its tip and told the sequencer the tempo. This crate is that unit: **frames in, beats
//! out**. It is pure (no clock, no file, no device in [`Baton`] and the types it is made of):
//! each frame comes with its time, and each beat it finds is a [`Beat`] `{ t_ms, bpm, x, y }`
//! that a tempo source can hand to the performer (`orch_perform::Control::set_tempo`).
//!
//! The pipeline, one stage a module, every parameter documented where it is defined:
//!
//! 1. [`blob`]: red pixels (`r ≥ 120`, `r − max(g, b) ≥ 60`) grouped into blobs, each with a
//!    sub-pixel centroid weighted by redness ([`DetectParams`]).
//! 2. [`track`]: which blob is the LED: small and thin (a streak when blurred), gated around
//!    the predicted position, the running track preferred, static red lights remembered,
//!    coasting through missed frames and the LED leaving the picture ([`TrackParams`]).
//! 3. [`beat`]: the ictus at the bottom of each downstroke (the turn from down to up, its
//!    time refined below the frame by fitting a V to the samples around the bottom), and a
//!    robust tempo: the recent intervals checked against the running estimate, outliers (a
//!    missed or invented beat, a fermata) ignored, a sudden change adopted once two intervals
//!    agree on it, the trend of an accelerando or a ritardando followed ([`BeatParams`]).
//!
//! **Latency**: a beat is confirmed two samples after the bottom one (one, if that one has
//! already risen half the stroke, as when frames are lost), so it is known 2 frames after the
//! ictus (33 ms at 60 fps, 67 ms at 30); its `t_ms` is the ictus's own, so a tempo source can
//! place the beat where it was. **A fermata**: a baton held still makes no beat (no stroke),
//! the long interval across it is an outlier to the tempo, and the tempo before it is kept.
//!
//! **To the performer**: `orch_perform::Tempo` is a factor of the score's own tempo, so a
//! tempo source divides [`Beat::bpm`] by the score's BPM at that point and calls
//! `Control::set_tempo`; [`Baton::next_beat_ms`] gives the phase (when the next beat is due).
//!
//! The harness's figures (every video of [`synth::suite`] at 30 and 60 fps: tempo error,
//! beat time error, missed and invented beats) and the tracker's speed are printed by
//! `cargo bench -p orch-baton --bench harness` and `--bench speed`.
//!
//! Around it: [`source`] reads frames from a `.y4m` file, a folder of numbered PNGs, or any
//! video through an `ffmpeg` subprocess (the only I/O here; a V4L2 camera would be one more
//! [`source::FrameSource`]); [`synth`] is the evaluation harness: it draws conductor videos
//! with known beats (steady, accelerando, ritardando, fermata, clutter, a second red object,
//! motion blur, noise, dropped frames, the LED leaving the picture, an overexposed LED) and
//! scores the tracker on them.
//!
//! ```
//! use orch_baton::{synth, Baton};
//!
//! // Two bars at 120 BPM, 30 fps, drawn in memory.
//! let video = synth::Video::new(synth::Script::steady("demo", 120.0, 30.0).beats(8));
//! let mut baton = Baton::default();
//! let beats: Vec<_> = video.frames().filter_map(|(t, f)| baton.push(t, &f)).collect();
//! assert_eq!(beats.len(), 8);
//! let bpm = beats.last().unwrap().bpm.unwrap();
//! assert!((bpm - 120.0).abs() < 1.0);
//! ```
//!
//! ## Cargo features
//!
//! - `camera` (off by default): [`camera::Camera`], a live camera through Video4Linux2
//!   (`/dev/video0`), YUYV or Motion JPEG converted to the tracker's frames. It builds the
//!   `v4l` crate, whose kernel bindings are generated at build time with libclang
//!   (`libclang-dev` on Debian); no libv4l is linked.
//!
//! `png` and `y4m` are plain dependencies: pure Rust, no system library.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod beat;
pub mod blob;
#[cfg(feature = "camera")]
pub mod camera;
pub mod frame;
pub mod source;
pub mod synth;
pub mod track;

pub use beat::{Beat, BeatDetector, BeatParams};
pub use blob::{Blob, DetectParams, Detector};
pub use frame::Frame;
pub use track::{Seen, TrackParams, Tracker};

/// Every parameter of the pipeline.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Params {
    /// Red pixels and blobs.
    pub detect: DetectParams,
    /// Following the LED.
    pub track: TrackParams,
    /// Beats and tempo.
    pub beat: BeatParams,
}

/// The whole unit: frames (with their times) in, beats out.
#[derive(Clone, Debug, Default)]
pub struct Baton {
    detector: Detector,
    tracker: Tracker,
    beats: BeatDetector,
    blobs: Vec<Blob>,
    last: Option<(f64, f64)>,
}

impl Baton {
    /// A unit with these parameters.
    pub fn new(params: Params) -> Self {
        Self {
            detector: Detector::new(params.detect),
            tracker: Tracker::new(params.track),
            beats: BeatDetector::new(params.beat),
            blobs: Vec::new(),
            last: None,
        }
    }

    /// One frame taken at `t_ms` (times increasing; gaps from dropped frames are fine). A
    /// beat when this frame confirms one (its `t_ms` is the ictus's, a little earlier).
    pub fn push(&mut self, t_ms: f64, frame: &Frame) -> Option<Beat> {
        let mut blobs = std::mem::take(&mut self.blobs);
        self.detector.detect(frame, &mut blobs);
        let beat = self.push_blobs(t_ms, &blobs);
        self.blobs = blobs;
        beat
    }

    /// One frame's blobs (from a [`Detector`] of one's own, or another LED finder).
    pub fn push_blobs(&mut self, t_ms: f64, blobs: &[Blob]) -> Option<Beat> {
        let was_tracking = self.tracker.tracking();
        let seen = self.tracker.update(t_ms, blobs);
        if seen.new_track || (was_tracking && !self.tracker.tracking()) {
            self.beats.reset_stroke();
        }
        self.last = seen.at;
        let (x, y) = seen.at?;
        self.beats.push(t_ms, x, y)
    }

    /// Where the LED was in the last frame, if it was found.
    pub fn led(&self) -> Option<(f64, f64)> {
        self.last
    }

    /// The tempo now (BPM), if two beats have been seen.
    pub fn bpm(&self) -> Option<f64> {
        self.beats.bpm()
    }

    /// When the next beat is due at the present tempo (ms on the frames' clock).
    pub fn next_beat_ms(&self) -> Option<f64> {
        self.beats.next_beat_ms()
    }
}
