//! Why the simulator refused or stopped.

use control::kinematics::KinematicsError;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The scene cannot be simulated with this configuration.
    #[error("scene {scene}: {message}")]
    Scene { scene: String, message: String },
    /// The configuration's geometry is unusable.
    #[error("configuration: {0}")]
    Config(String),
    /// A kinematic map refused (initial pose out of reach, ...).
    #[error("kinematics: {0}")]
    Kinematics(#[from] KinematicsError),
    /// A command was not finite.
    #[error("refused non-finite {0}")]
    NonFinite(&'static str),
    /// The other end of the rig (the tactile port or the arm) was dropped.
    #[error("the simulated {0} is gone")]
    Disconnected(&'static str),
    /// The tracker named is not built in.
    #[error("unknown tracker {name:?} (known: {known})")]
    UnknownTracker { name: String, known: String },
    /// The control code refused (a PD trip, a planner error).
    #[error("control: {0}")]
    Control(String),
}
