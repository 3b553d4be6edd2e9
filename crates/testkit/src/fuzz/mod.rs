//! The fuzz targets' checks (`fuzz/`, its own workspace on nightly), shared with the stable-Rust
//! tests that replay each target's corpus and regressions: one module a target, each behind a
//! feature of its own so that a test takes only the crates its target reads.

#[cfg(feature = "fuzz-interpret")]
pub mod interpret;
pub mod replay;
#[cfg(feature = "fuzz-robot-toml")]
pub mod robot_toml;
#[cfg(feature = "fuzz-rtp")]
pub mod rtp;
#[cfg(feature = "fuzz-smf")]
pub mod smf;
