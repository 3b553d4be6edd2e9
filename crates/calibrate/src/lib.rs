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
//! # Strike outputs
//! A robot's `[[strike]]` outputs (drums, bars) are struck after the keys, level by level, 3 s
//! apart ([`score`]; a robot without keys syncs on three of them, [`outputs`] says which note
//! and channel strike each). A drum has no partials: each hit is heard on the recording's
//! broadband energy (2 ms windows, the start of the rise over the noise: `hits`), fitted as a
//! key is, its flight line on the hits 20 dB or more over the noise ([`strikes`]), and written
//! as each `[[strike.output]]`'s `flight`/`soft_flight` (a pitched group: its bars' median in
//! its `[[strike]]`), the outputs' loudness as a comment. [`synthetic::kit`] makes synthetic
//! drum recordings (`tests/strikes.rs`, `--bench strikes`); `--bench rendered_drums`
//! renders the kit through TimGM6mb.
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
//! crosses half-way to its peak, then refined on the recording's high-passed energy (the
//! key's 4th partial up, 3 ms windows): where it has risen a fifth of the way to its level
//! after the onset. The partials' bands cannot time an abrupt onset closer than a part of
//! the key's period (the onset's click spreads over each band); the broadband energy can, to
//! a fraction of its window. A strike too soft for the energy to rise clearly (15 dB) is
//! timed on the envelope moved by the key's own offset between the two (from its louder
//! strikes). The level is the string power from the onset on, over one span for all of a
//! key's strikes (100 ms, or less so that it ends before its slowest strike's pin goes low);
//! a second onset for one strike counts only where it rises abruptly. Every parameter,
//! and why, is in the `listen` and `envelope` modules' source notes.
//!
//! # Real rooms
//! - **Noise**: every threshold is set from the noise (the recording's flux for the figure;
//!   each key's frames before its strikes for the key), so it rises with the room's noise;
//!   listening on the key's partials alone gains about 15 dB over the whole band. A strike
//!   whose partials do not rise clearly above the noise in their own bins counts as silence;
//!   at 30 dB SNR that is about 55 dB below the key's full-power level (the virtual robot's
//!   softest sound is −36 dB). The sharp timing needs the strike's high-passed energy 15 dB
//!   above the noise's; a softer strike is timed on the envelope and its key's offset.
//! - **Reverberation**: the detection function only counts rises, and each strike has a
//!   second to itself (the damper stops the string 175 ms after the press; the room's tail
//!   has died 60 dB in 0.6 s); an echo's ripple in the flux is ignored under 15 % of the
//!   onset's peak. The direct sound comes first, so the sharp timing's rise is the direct
//!   sound's; the partials' envelope crossing moves with the early reflections (±2 ms at a
//!   direct-to-reverberant ratio of 0 dB), which is why it only guides the sharp timing.
//!   As the direct sound dies, a high key's partial can swell against the reverberation to
//!   twice its power, with a flux peak over 15 % of the strike's: a second onset counts only
//!   where the sharp timing finds an abrupt rise, which a swell has not.
//! - **A mechanical thump before the string**: a click of a few ms spreads its energy over
//!   the whole spectrum, so the partials' narrow bands, on whose envelope the onset is first
//!   timed, get little of it next to the string's; its flux peak, a frame or less before the
//!   string's, merges with it into one onset (the merge is what the thump test guards: with
//!   it shortened to 5 ms the thump becomes a second onset). The sharp timing is broadband
//!   and could take the thump: its rise must last 5 ms (a click's falls back), must not
//!   have begun before its search window, and must lie within 0.4 periods plus 15 ms of the
//!   envelope's onset. A solenoid's thump 2–5 ms before the string runs into the string
//!   without falling back, so the onset is also looked for where the string's *periodicity*
//!   starts (the high-passed signal times itself a whole number of the key's periods later:
//!   a thump does not repeat); where that comes more than 1 ms after the energy's rise (1.5
//!   ms after a soft strike's envelope timing), it is the onset, or where the periodicity a
//!   period further on starts, if that is earlier and still after the energy's rise. Soft strikes in the two lowest
//!   octaves, where the thump's low thud is as loud as the string in the key's own bands,
//!   can still come out a few ms off (`--bench thump`). The thump is not measured.
//! - **A neighbour's decay still ringing**: keys are struck in order, a second apart, each
//!   key's own noise frames (from 450 to 150 ms before each strike) hold whatever still
//!   rings, so its threshold and string-power baseline include it; the timing crosses
//!   half-way from that baseline.
//!
//! # The fit
//! The model is the virtual robot's (see [`fit`]): sound at or above `softest`, press delay
//! and velocity-scale loudness linear in the duty, and loudness heard as `orch render`
//! plays it (loudness 1..=127 as synthesizer velocity 16..=127, `40 log10(velocity / 127)`
//! dB: −36 to 0 dB), each key against its own full-power level.
//!
//! - **The sound's attack**: the onset is where the sound rises, so a key whose sound rises
//!   slowly (a sampled bass note, a soundfont's quiet pre-roll) is timed later than its first
//!   sample by its attack: the press delay measured is to the audible onset, which is what
//!   compensation needs.
//!
//! # Synthetic recordings
//! [`synthetic`] makes recordings of the score by a robot with hidden figures, in a room
//! with noise, reverberation and a capture offset: the tests and the accuracy figures
//! (`cargo bench -p orch-calibrate --bench accuracy`) use it. The proof on
//! *rendered* sound (the virtual robot with hidden per-key mechanics playing the score,
//! `orch-render` making it sound) is in the crate's tests (`tests/rendered.rs`) and
//! `cargo bench -p orch-calibrate --bench rendered`.
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
mod hits;
mod listen;
#[cfg(feature = "mic")]
pub mod live;
#[cfg(feature = "mic")]
pub mod mic;
mod onset;
pub mod outputs;
mod robot_strikes;
pub mod robot_toml;
pub mod score;
mod sharp;
mod spectrum;
pub mod strikes;
mod sync;
pub mod synthetic;
pub mod wav;

pub use analyze::{analyze, Anchor, AnchorUsed, Calibration, KeyFigures, KeyResult, Level};
pub use error::CalibrateError;
pub use outputs::Output;
pub use score::{Score, Strike};
pub use strikes::{OutputFigures, OutputResult};
pub use wav::Recording;
