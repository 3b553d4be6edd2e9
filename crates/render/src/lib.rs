//! # orch-render: hear the virtual robot
//!
//! A builder cannot hear a robot that does not exist yet. This crate turns the virtual
//! robot's performance into sound: each strike sounds when the virtual robot says it does,
//! at its loudness; late, dropped, joined and too-soft notes sound (or do not) as they would
//! on the robot; each key's sound stops when the key is fully up again. A drum kit plays
//! through the soundfont's General MIDI drum kit (each strike the drum the score asked for), a
//! glockenspiel through its General MIDI program at its bars' pitches, the keyboard on the
//! piano, all in one mix; a drum or bar rings on after its strike, as one does. The score
//! itself renders the same way (every note at its score time and velocity, channel 10 on the
//! drum kit), to listen side by side.
//! `orch render` is its command line.
//!
//! - [`events`]: what the keys do, from a performance ([`events::from_robot`]: which
//!   data gives the strike times, the loudness, the key-ups and each output's sound is said
//!   there; how long a strike rings) or from the score ([`events::from_song`]).
//! - [`synth`]: key events to samples through a SoundFont, every strike's first sound on its
//!   own sample (64 synthesizers side by side, a block phase each; each voice started
//!   early by the soundfont's own silent lead, measured per instrument, note and velocity).
//! - [`lead`]: how long each note of a soundfont is silent after its voice starts.
//! - [`soundfont`]: the user's soundfont, or one a Debian package installed.
//! - [`wav`]: stereo 32-bit float WAV files through `hound`.
//! - [`onset`]: strikes found in rendered audio, to check a render against the robot.
//!
//! ## The synthesizer: rustysynth
//!
//! Candidates, all SoundFont 2 players in Rust:
//!
//! | crate | licence | for | timing |
//! |---|---|---|---|
//! | `rustysynth` 1.3 | MIT | offline and real-time rendering; a port of MeltySynth; no dependencies | events at its block's start; blocks of 8..=1024 samples |
//! | `oxisynth` 0.1 | LGPL-2.1 | a port of FluidSynth | FluidSynth's fixed 64-sample blocks |
//! | `xsynth-core` | LGPL-3.0 | very many voices ("black MIDI"), real time | block-based |
//! | `rustysynth-ext` | MIT | a fork of rustysynth adding SoundFont 3 | as rustysynth |
//!
//! rustysynth: its licence is one this project (MIT OR Apache-2.0) can link statically
//! without conditions (the LGPL ones would ask every binary to be relinkable), it has no
//! dependencies, it renders offline as fast as the machine goes, its blocks can be as short
//! as 8 samples (which makes exact strike times cheap: see [`synth`]), and it is the
//! upstream the fork follows. SoundFont 3 (Ogg-compressed) is not needed: Debian's fonts
//! are SoundFont 2.
//!
//! ```no_run
//! use orch_render::{events, soundfont, synth, wav, Instrument, Loudness};
//! # fn main() -> Result<(), orch_render::RenderError> {
//! let font = soundfont::load(&soundfont::find(None)?)?;
//! // Middle C struck at 0.5 s at velocity 100, released at 1.5 s.
//! let keys = [
//!     events::KeyEvent {
//!         at_ns: 500_000_000,
//!         note: 60,
//!         instrument: Instrument::PIANO,
//!         action: events::Action::Strike { loudness: Loudness::of_velocity(100) },
//!     },
//!     events::KeyEvent {
//!         at_ns: 1_500_000_000,
//!         note: 60,
//!         instrument: Instrument::PIANO,
//!         action: events::Action::Release,
//!     },
//! ];
//! let settings = synth::Settings::default();
//! let mut out = wav::WavOut::create("c.wav".as_ref(), settings.sample_rate)?;
//! synth::render(&font, &keys, &settings, |l, r| out.write(l, r))?;
//! out.finish()?;
//! # Ok(())
//! # }
//! ```
//!
//! ## Cargo features
//!
//! None.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
pub mod events;
mod exclusive;
pub mod lead;
pub mod onset;
pub mod soundfont;
pub mod synth;
pub mod wav;

pub use error::RenderError;
pub use events::{Action, Instrument, KeyEvent, Output, StrikeNote};
pub use orch_sim::Loudness;
pub use rustysynth::SoundFont;
pub use synth::{render, Rendered, Settings};
