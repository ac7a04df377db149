//! The PD joint controller.

pub mod params;

pub use params::PdParams;
