//! Kinematics of the Phantom 1.5 holding a rod through a fixed pivot.
//!
//! - [`phantom`]: joints <-> gimbal point G (robot base frame), Jacobian, joint limits;
//! - [`pivot`]: gimbal point <-> rod tip T through the fixed pivot, with depth guards;
//! - [`arm::ArmModel`]: the composed map joints <-> sensor centre in the tissue frame.
//!
//! Frames, formulas, branches and limits are written up in docs/kinematics.md.

pub mod arm;
mod error;
pub mod params;
pub mod phantom;
pub mod pivot;
pub mod rod_load;

pub use arm::ArmModel;
pub use error::KinematicsError;
pub use params::{
    DEFAULT_SENSOR_OFFSET_M, DEFAULT_SURFACE_DEPTH_M, JointLimits, PhantomGeometry, PivotGeometry,
    tissue_under_pivot,
};
pub use rod_load::{RodAt, RodLoadError, RodMechanics};
