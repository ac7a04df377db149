//! PD joint controller settings.

use serde::{Deserialize, Serialize};

use crate::types::Joints;

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PdParams {
    /// Proportional gain per joint, N·m/rad.
    pub kp_nm_per_rad: Joints,
    /// Derivative gain per joint, N·m·s/rad.
    pub kd_nm_s_per_rad: Joints,
    /// Absolute torque limit per joint, N·m (at the joint, after the capstan).
    pub torque_limit_nm: Joints,
    /// Largest change of commanded torque per second, N·m/s.
    pub torque_rate_limit_nm_per_s: Joints,
    /// Setpoint minus measured position beyond which the controller trips, rad.
    pub max_tracking_error_rad: Joints,
}

impl Default for PdParams {
    fn default() -> Self {
        // Low gains for smooth sliding, as the seed used; the motor's 28.6 mN·m continuous
        // through capstans of 13.3 / 11.2 / 11.2 gives about 0.38 / 0.32 / 0.32 N·m.
        Self {
            kp_nm_per_rad: [8.0, 8.0, 8.0],
            kd_nm_s_per_rad: [0.08, 0.08, 0.08],
            torque_limit_nm: [0.38, 0.32, 0.32],
            torque_rate_limit_nm_per_s: [40.0, 40.0, 40.0],
            max_tracking_error_rad: [0.15, 0.15, 0.15],
        }
    }
}
