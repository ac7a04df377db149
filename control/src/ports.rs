//! The ports: what hardware must provide for the core to drive it.
//!
//! A real driver (serial tactile array, CAN joint bus) and the simulator implement the same
//! traits, so the controllers and trackers cannot tell which they are talking to. Ports are
//! synchronous and never block for long: the 1 kHz loop calls them every cycle. Time is never
//! read here; implementations stamp data with the caller's monotonic clock.

use crate::types::{JointState, JointTorques, TactileFrame};

/// A torque-controlled arm: read joint state, write joint torques, switch power.
pub trait Manipulator {
    type Error: std::error::Error + Send + Sync + 'static;

    /// Power the amplifiers. Torques written while disabled are not applied.
    fn enable(&mut self) -> Result<(), Self::Error>;

    /// Remove power from every axis and drop any command not yet sent.
    fn disable(&mut self) -> Result<(), Self::Error>;

    /// The latest measured joint state.
    fn read_joints(&mut self) -> Result<JointState, Self::Error>;

    /// Command joint torques for the coming cycle. Callers check finiteness first; an
    /// implementation still refuses non-finite values.
    fn write_torques(&mut self, torques: &JointTorques) -> Result<(), Self::Error>;

    /// Clear a fault latched in the arm (a lost bus, an amplifier fault, an e-stop) once its
    /// cause is gone, without powering anything: the arm stays disabled until `enable`.
    /// While the cause is still present it returns an error naming it. Never blocks: a
    /// caller waiting for the cause to clear calls it again. An arm that latches nothing of
    /// its own has nothing to clear.
    fn recover(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// A tactile array streaming timestamped frames.
pub trait TactileArray {
    type Error: std::error::Error + Send + Sync + 'static;

    /// The next frame that arrived since the previous call, oldest first, or `None` if there
    /// is none yet. Never blocks. Staleness is judged by the caller with
    /// [`crate::staleness::StalenessMonitor`] against the frames' timestamps.
    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, Self::Error>;
}
