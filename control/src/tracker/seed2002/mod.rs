//! `seed2002`: the tracker of Beasley & Howe (2002), reproduced as a named baseline.
//!
//! docs/seed2002.md documents the algorithm as implemented, each constant and its source,
//! and every reading of the paper.

pub mod machine;
pub mod params;

pub use machine::{InvalidParams, Seed2002};
pub use params::Seed2002Params;
