//! The PD joint controller: one step per servo cycle, no allocation, every number checked.
//!
//! `τ = kp (q* − q) + kd (q̇* − q̇) + g(q)` per joint, then clamped to the torque limit and
//! rate-limited against the previous command. A position error beyond the configured limit
//! trips the controller, and any non-finite input or output is refused. After a fault the
//! caller disables the arm; [`PdController::reset`] (on enable or reset) restarts the rate
//! limiter from zero torque so that power comes on without a torque step.

pub mod gravity;
pub mod params;
pub mod stability;

use thiserror::Error;

pub use gravity::{GravityModel, NoGravity, PhantomGravity, PhantomMasses, PointMass};
pub use params::PdParams;

pub use crate::types::JointSetpoint;
use crate::types::{JOINTS, JointState, JointTorques, Joints};

#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum PdFault {
    /// Setpoint minus measured position beyond the trip limit (joint index from 0).
    #[error("joint {joint} tracking error {error_rad:.4} rad exceeds {limit_rad:.4} rad")]
    TrackingError {
        joint: usize,
        error_rad: f64,
        limit_rad: f64,
    },
    /// An input or the computed torque was NaN or infinite.
    #[error("{what} is not finite")]
    NonFinite { what: &'static str },
    /// The time step was not a positive finite number.
    #[error("time step {dt_s} s is not a positive finite number")]
    InvalidTimeStep { dt_s: f64 },
    /// The settings cannot drive an arm safely.
    #[error("invalid PD settings: {what}")]
    InvalidParams { what: &'static str },
}

#[derive(Debug, Clone)]
pub struct PdController {
    params: PdParams,
    last: JointTorques,
}

fn finite(what: &'static str, v: &Joints) -> Result<(), PdFault> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(PdFault::NonFinite { what })
    }
}

fn check_params(p: &PdParams) -> Result<(), PdFault> {
    let non_negative = |v: &Joints| v.iter().all(|x| x.is_finite() && *x >= 0.0);
    let positive = |v: &Joints| v.iter().all(|x| x.is_finite() && *x > 0.0);
    let bad = |what| Err(PdFault::InvalidParams { what });
    if !non_negative(&p.kp_nm_per_rad) {
        return bad("kp_nm_per_rad must be finite and not negative");
    }
    if !non_negative(&p.kd_nm_s_per_rad) {
        return bad("kd_nm_s_per_rad must be finite and not negative");
    }
    if !positive(&p.torque_limit_nm) {
        return bad("torque_limit_nm must be positive");
    }
    if !positive(&p.torque_rate_limit_nm_per_s) {
        return bad("torque_rate_limit_nm_per_s must be positive");
    }
    if !positive(&p.max_tracking_error_rad) {
        return bad("max_tracking_error_rad must be positive");
    }
    Ok(())
}

impl PdController {
    /// A controller at rest (last command zero). Refuses settings that are negative, zero
    /// where a limit is needed, or not finite.
    pub fn new(params: PdParams) -> Result<Self, PdFault> {
        check_params(&params)?;
        Ok(Self {
            params,
            last: JointTorques::ZERO,
        })
    }

    pub fn params(&self) -> &PdParams {
        &self.params
    }

    /// The last torque commanded (zero after [`Self::reset`]).
    pub fn last_torque(&self) -> JointTorques {
        self.last
    }

    /// Forget the last command: the rate limiter starts again from zero torque. Call on
    /// enable and on reset.
    pub fn reset(&mut self) {
        self.last = JointTorques::ZERO;
    }

    /// One servo cycle: the torque to command for `dt_s` seconds. On a fault the controller
    /// keeps its last command unchanged; the caller disables the arm and resets.
    pub fn step(
        &mut self,
        setpoint: &JointSetpoint,
        state: &JointState,
        gravity_nm: &Joints,
        dt_s: f64,
    ) -> Result<JointTorques, PdFault> {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(PdFault::InvalidTimeStep { dt_s });
        }
        finite("setpoint position", &setpoint.position_rad)?;
        finite("setpoint velocity", &setpoint.velocity_rad_s)?;
        finite("measured position", &state.position_rad)?;
        finite("measured velocity", &state.velocity_rad_s)?;
        finite("gravity torque", gravity_nm)?;
        let p = &self.params;
        let mut out = JointTorques::ZERO;
        // Per-joint arithmetic over six parallel arrays reads best indexed.
        #[allow(clippy::needless_range_loop)]
        for j in 0..JOINTS {
            let error_rad = setpoint.position_rad[j] - state.position_rad[j];
            if !error_rad.is_finite() {
                return Err(PdFault::NonFinite {
                    what: "position error",
                });
            }
            if error_rad.abs() > p.max_tracking_error_rad[j] {
                return Err(PdFault::TrackingError {
                    joint: j,
                    error_rad,
                    limit_rad: p.max_tracking_error_rad[j],
                });
            }
            let rate_error = setpoint.velocity_rad_s[j] - state.velocity_rad_s[j];
            let wanted =
                p.kp_nm_per_rad[j] * error_rad + p.kd_nm_s_per_rad[j] * rate_error + gravity_nm[j];
            let limit = p.torque_limit_nm[j];
            let clamped = wanted.clamp(-limit, limit);
            let max_change = p.torque_rate_limit_nm_per_s[j] * dt_s;
            let previous = self.last.torque_nm[j];
            out.torque_nm[j] = previous + (clamped - previous).clamp(-max_change, max_change);
        }
        // A NaN cannot get through clamp unnoticed: `wanted` NaN stays NaN, caught here.
        if !out.is_finite() {
            return Err(PdFault::NonFinite {
                what: "commanded torque",
            });
        }
        self.last = out;
        Ok(out)
    }
}

#[cfg(test)]
#[path = "pd_tests.rs"]
mod tests;
