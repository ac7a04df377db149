//! The 1 kHz joint loop: rate, PD gains and tip motion.

use control::motion::MotionParams;
use control::pd::PdParams;
use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControlSection {
    /// Servo rate, Hz (the Phantom: 1 kHz).
    pub rate_hz: f64,
    pub pd: PdParams,
    pub motion: MotionParams,
}

impl Default for ControlSection {
    fn default() -> Self {
        Self {
            rate_hz: 1000.0,
            pd: PdParams::default(),
            motion: MotionParams::default(),
        }
    }
}

impl Validate for ControlSection {
    fn validate(&self, v: &mut Validator) {
        v.in_range("rate_hz", self.rate_hz, 10.0, 10_000.0);
        v.at("pd", |v| {
            let pd = &self.pd;
            v.all_non_negative("kp_nm_per_rad", &pd.kp_nm_per_rad);
            v.all_non_negative("kd_nm_s_per_rad", &pd.kd_nm_s_per_rad);
            v.all_positive("torque_limit_nm", &pd.torque_limit_nm);
            v.all_positive("torque_rate_limit_nm_per_s", &pd.torque_rate_limit_nm_per_s);
            v.all_positive("max_tracking_error_rad", &pd.max_tracking_error_rad);
        });
        v.at("motion", |v| {
            let m = &self.motion;
            v.positive("max_speed_m_s", m.max_speed_m_s);
            v.positive("accel_m_s2", m.accel_m_s2);
            v.positive("settle_tolerance_m", m.settle_tolerance_m);
            v.positive("settle_speed_m_s", m.settle_speed_m_s);
            v.in_range("contact_height_m", m.contact_height_m, -0.02, 0.02);
            v.non_negative("settle_timeout_s", m.settle_timeout_s);
            v.non_negative("trim_rate_per_s", m.trim_rate_per_s);
            v.in_range("trim_max_m", m.trim_max_m, 0.0, 0.01);
        });
    }
}
