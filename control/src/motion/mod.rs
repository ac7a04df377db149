//! Moving the sensor between tracker targets.

pub mod params;

pub use params::MotionParams;
