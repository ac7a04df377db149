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
        // Low gains for smooth sliding, as the seed used: 140-360 N/m laterally and 330-490
        // N/m vertically at the sensor over the default patch (a Phantom renders up to
        // ~3.5 N/mm), yet
        // stable with margin at 1 kHz for every joint inertia from the bare arm's to the arm's
        // with rod and the seed's 0.3 kg mass: see docs/kinematics.md and pd::stability.
        // Torque limits are the motors' 28.6 mN·m continuous through capstans of 13.3 / 11.2
        // / 11.2. The rate limit ramps a full-scale torque in ~7 ms: no steps on enable, but
        // faster than the loop's own dynamics so it does not destabilise it.
        Self {
            kp_nm_per_rad: [25.0, 20.0, 20.0],
            kd_nm_s_per_rad: [0.5, 0.4, 0.3],
            torque_limit_nm: [0.38, 0.32, 0.32],
            torque_rate_limit_nm_per_s: [50.0, 50.0, 50.0],
            max_tracking_error_rad: [0.08, 0.08, 0.08],
        }
    }
}
