//! Test support.

pub mod rendered;
