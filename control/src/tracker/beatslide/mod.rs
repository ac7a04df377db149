//! `beatslide`: one localization per heartbeat while sliding along the artery.
//!
//! What the seed (docs/seed2002.md) lists as future work, built on what the simulator
//! shows: sub-element localization by fitting the tube's pressure kernel (out-of-phase far
//! elements included), lock-in detection synchronized to a beat clock so that the sensor
//! samples while it slides, a Kalman filter on the path's position, heading and curvature
//! instead of a line through four points, and a step and speed chosen from that filter's
//! confidence and the pulse's strength. docs/tracker-beatslide.md describes it and its
//! measurements.

mod beat_fix;
mod drag;
mod history;
mod machine;
mod params;
pub mod path_filter;
mod path_modes;
mod tissue_motion;

pub use beat_fix::{BeatFix, BeatMiss, SpatialPrior, analyse_window, spatial_weights};
pub use drag::Drag;
pub use history::{History, Window};
pub use machine::{BeatSlide, InvalidParams, Miss};
pub use params::BeatSlideParams;
pub use path_filter::{
    Observation, PathFilter, PathFilterError, PathFilterSettings, Prediction, Surprise,
};
pub use tissue_motion::TissueMotion;
