//! Tip motion settings: how the sensor is moved between tracker targets.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionParams {
    /// Upper bound on any commanded sensor speed, m/s.
    pub max_speed_m_s: f64,
    /// Acceleration of the straight-line setpoint profile, m/s².
    pub accel_m_s2: f64,
    /// A move has arrived when the believed sensor centre is this close to the target, m
    /// (the seed: 1 mm).
    pub settle_tolerance_m: f64,
    /// ... and moving slower than this, m/s.
    pub settle_speed_m_s: f64,
    /// A move whose setpoint has finished counts as settled after this long even if the
    /// tolerance is not met (low-gain PD against friction may never get within it), s.
    pub settle_timeout_s: f64,
}

impl Default for MotionParams {
    fn default() -> Self {
        Self {
            max_speed_m_s: 0.03,
            accel_m_s2: 0.1,
            settle_tolerance_m: 0.001,
            settle_speed_m_s: 0.002,
            settle_timeout_s: 2.0,
        }
    }
}
