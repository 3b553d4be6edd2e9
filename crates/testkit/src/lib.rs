//! # testkit: what orch's tests share
//!
//! Not published: a dev-dependency of the workspace's crates, so that no test reaches into
//! another crate's directory for its helpers.
//!
//! - [`smf`]: Standard MIDI Files built in a line ([`smf::one_track`], [`smf::at_ticks`],
//!   [`smf::smf`]) and the quarter-note song many tests play ([`smf::quarters_smf`]).
//! - [`examples`]: a crate's teaching example run as its user runs it, its output given back.
//! - `conducted` (feature `conduct`): a conductor on the virtual clock, its beats through a
//!   source's decoder and the follower to a performance.
//! - `sf2` (feature `sf2`): SoundFonts written here, whose sound starts on its first sample.
//! - [`Scratch`], [`in_test`]: a test's scratch folder, removed when it ends.
//! - [`lines`]: the function-length scanner the crates' `function_length` tests share.
//! - [`fuzz`]: the fuzz targets' checks (features `fuzz-interpret`, `fuzz-smf`, `fuzz-rtp`,
//!   `fuzz-robot-toml`) and the replay of a corpus through them.
//!
//! ```
//! // Middle C for a quarter note, at 120 bpm (480 ticks a quarter).
//! let bytes = testkit::smf::one_track(&[(0, &[0x90, 60, 100]), (480, &[0x80, 60, 0])]);
//! assert_eq!(&bytes[..4], b"MThd");
//! ```

#[cfg(feature = "conduct")]
pub mod conducted;
pub mod examples;
pub mod fuzz;
pub mod lines;
mod scratch;
#[cfg(feature = "sf2")]
pub mod sf2;
pub mod smf;

pub use scratch::{in_test, Scratch};
