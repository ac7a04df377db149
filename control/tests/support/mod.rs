//! Test support shared by control's integration tests and examples (dev-only).

#![allow(dead_code)]

pub mod synth;
pub mod world;
