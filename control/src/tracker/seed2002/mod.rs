//! `seed2002`: the tracker of Beasley & Howe (2002), reproduced as a named baseline.

pub mod params;

pub use params::Seed2002Params;
