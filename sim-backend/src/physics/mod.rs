//! The physics of the bench: what the sensor feels and how the arm, rod and tissue move.

pub mod applanation;
pub mod contact;
pub mod joints;
pub mod kernel;
pub mod rod;
pub mod tactile;
