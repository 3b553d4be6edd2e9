//! Calibrating a solenoid piano robot by ear: `orch calibrate`'s library.
//!
//! 1. **The score** ([`Score`]): an opening sync figure, then every key of the robot struck
//!    alone at N velocity levels, softest first, one strike a second ([`score`] says why
//!    each figure). [`Score::schedule`] lists what it asks (key, velocity, time);
//!    [`Score::to_smf`] writes it as a Standard MIDI File. Play it on the robot **without
//!    latency compensation** (`orch play CAL.mid --no-compensation --out …`), so that each
//!    note is sent at its score time, and record it.
//! 2. **The recording** ([`Recording::read`]): WAV, 16/24-bit integer or 32-bit float,
//!    16–192 kHz, channels mixed to mono. Refused with a [`CalibrateError`]: not a WAV,
//!    another format, silence (peak below −60 dBFS), clipped through most of it, too short
//!    for the score, or without the sync figure.
//! 3. **The analysis** ([`analyze()`]): the sync figure found among the broadband onsets
//!    ([`onset`](crate#onsets) below) gives the capture offset; each key is then listened
//!    for in a window after each of its strikes ([`listen`](crate#listening-for-a-key)); each
//!    strike must give exactly one onset, or it is a problem of that key, never fitted; each
//!    key's figures are fitted ([`fit`]); the press delays are pinned by an [`Anchor`] (one
//!    key's true press delay) or, without one, to the robot file's value for middle C.
//! 4. **The result**: [`Calibration`] (the measurements, `--json`), and
//!    [`robot_toml::calibrated`], the input robot.toml with `[[mechanics.key]]` and
//!    `[[dynamics.key]]` filled in.
//!
//! # Onsets
//! The sync figure is found on broadband onsets: spectral flux on log-compressed magnitudes,
//! half-wave rectified, with an adaptive threshold and peak picking (Dixon 2006, "Onset
//! detection revisited"). Each onset is tried as the figure's first strike; the others must
//! be there at their times (±50 ms), with no other onset in the figure's span.
//!
//! # Listening for a key
//! Within each strike's window the same flux is computed on the struck key's partials only
//! (a comb of bins), every 1 ms, with a threshold from the key's own noise frames; an onset
//! must also raise the key's *string power* (the partials' power less the power between
//! them) well above its noise. The onset is timed on the partials' analytic envelopes
//! (each partial's band through a zero-phase filter: no phase ripple), where their sum
//! crosses half-way to its peak; the level is the string power over the 50 ms after it.
//! Every parameter, and why, is in the `listen` and `envelope` modules' source notes.
//!
//! # Real rooms
//! - **Noise**: every threshold is set from the noise (the recording's flux for the figure;
//!   each key's frames before its strikes for the key), so it rises with the room's noise;
//!   listening on the key's partials alone gains about 15 dB over the whole band. A strike
//!   whose partials do not rise clearly above the noise in their own bins counts as silence;
//!   at 30 dB SNR that is about 55 dB below the key's full-power level (velocity-scale
//!   loudness about 10).
//! - **Reverberation**: the detection function only counts rises, and each strike has a
//!   second to itself (the damper stops the string 175 ms after the press; the room's tail
//!   has died 60 dB in 0.6 s); an echo's ripple in the flux is ignored under 15 % of the
//!   onset's peak.
//! - **A mechanical thump before the string**: a click of a few ms spreads its energy over
//!   the whole spectrum, so the partials' narrow bands, on whose envelope the onset is timed,
//!   get little of it next to the string's; its flux peak, a frame or less before the
//!   string's, merges with it into one onset (the merge is what the thump test guards: with
//!   it shortened to 5 ms the thump becomes a second onset). The thump is not measured.
//! - **A neighbour's decay still ringing**: keys are struck in order, a second apart, each
//!   key's own noise frames (from 450 to 150 ms before each strike) hold whatever still
//!   rings, so its threshold and string-power baseline include it; the timing crosses
//!   half-way from that baseline.
//!
//! # The fit
//! The model is the virtual robot's (see [`fit`]): sound at or above `softest`, press delay
//! and velocity-scale loudness linear in the duty, and loudness `v` heard as `40 log10(v /
//! 127)` dB (MIDI's DLS/SoundFont convention), each key against its own full-power level.
//!
//! # Synthetic recordings
//! [`synthetic`] makes recordings of the score by a robot with hidden figures, in a room
//! with noise, reverberation and a capture offset: the tests and the accuracy figures
//! (`cargo run --release -p orch-calibrate --example accuracy`) use it.
//!
//! # Recording live
//! With the `mic` feature, the `mic` module records from an ALSA capture device and `live`
//! plays the score on the robot through orch-stage's live session while recording it, the
//! recording lined up with the performance (`orch calibrate --out OUT --mic DEVICE`).
//!
//! ## Cargo features
//!
//! - `mic` (off by default): the `mic` and `live` modules, the live capture. It links alsa-lib
//!   (`libasound2-dev` to build) through the `alsa` crate, and brings orch-stage (the live
//!   session) in. Without it the crate reads recordings from WAV files only.

pub mod analyze;
mod envelope;
mod error;
pub mod fit;
mod listen;
#[cfg(feature = "mic")]
pub mod live;
#[cfg(feature = "mic")]
pub mod mic;
mod onset;
pub mod robot_toml;
pub mod score;
mod spectrum;
mod sync;
pub mod synthetic;
pub mod wav;

pub use analyze::{analyze, Anchor, AnchorUsed, Calibration, KeyFigures, KeyResult, Level};
pub use error::CalibrateError;
pub use score::{Score, Strike};
pub use wav::Recording;
