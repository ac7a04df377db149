//! Kinematics of the Phantom 1.5 holding a rod through a fixed pivot.

pub mod params;

pub use params::{JointLimits, PhantomGeometry, PivotGeometry};
