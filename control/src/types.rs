//! Domain types shared by every layer: joint state, torques and timestamped tactile frames.

use serde::{Deserialize, Serialize};

/// Actuated joints of the Phantom 1.5 (base yaw, upper-arm elevation, forearm angle).
pub const JOINTS: usize = 3;

/// Elements on the tactile array (a single line, 2 mm pitch, on the real sensor).
pub const ELEMENTS: usize = 10;

/// One value per actuated joint.
pub type Joints = [f64; JOINTS];

/// Measured joint state at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Time of the measurement, seconds on the caller's monotonic clock.
    pub t_s: f64,
    /// Joint angles θ1, θ2, θ3 (θ3 absolute, from vertical), rad.
    pub position_rad: Joints,
    /// Joint rates, rad/s.
    pub velocity_rad_s: Joints,
}

impl JointState {
    /// True if every number in the state is finite.
    pub fn is_finite(&self) -> bool {
        self.t_s.is_finite()
            && self.position_rad.iter().all(|v| v.is_finite())
            && self.velocity_rad_s.iter().all(|v| v.is_finite())
    }
}

/// Where the joint loop should hold the arm now: positions and the rates to follow.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct JointSetpoint {
    /// θ1, θ2, θ3, rad.
    pub position_rad: Joints,
    /// Feed-forward joint rates, rad/s.
    pub velocity_rad_s: Joints,
}

impl JointSetpoint {
    /// Hold still at `position_rad`.
    pub const fn at_rest(position_rad: Joints) -> Self {
        Self {
            position_rad,
            velocity_rad_s: [0.0; JOINTS],
        }
    }

    pub fn is_finite(&self) -> bool {
        self.position_rad.iter().all(|v| v.is_finite())
            && self.velocity_rad_s.iter().all(|v| v.is_finite())
    }
}

/// Joint torque command, N·m at the joint (after the capstan).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTorques {
    pub torque_nm: Joints,
}

impl JointTorques {
    pub const ZERO: Self = Self {
        torque_nm: [0.0; JOINTS],
    };

    pub fn is_finite(&self) -> bool {
        self.torque_nm.iter().all(|v| v.is_finite())
    }
}

/// One sample of the whole tactile array.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TactileFrame {
    /// Time the frame was sampled, seconds on the consumer's monotonic clock.
    pub t_s: f64,
    /// Frame counter from the source; gaps reveal dropped frames.
    pub seq: u64,
    /// Normal force on each element, N, element 0 first.
    pub force_n: [f64; ELEMENTS],
}

impl TactileFrame {
    pub fn is_finite(&self) -> bool {
        self.t_s.is_finite() && self.force_n.iter().all(|v| v.is_finite())
    }
}
