//! One joint's sweep toward one of its stops (docs/rig-bring-up.md section 1): a joint
//! setpoint ramped slowly from where the joint is toward the software limit plus the
//! overtravel, the other joints held, the swept joint's torque capped by the caller. The
//! stop is where the joint stalls (slower than `stall_speed_rad_s` with its torque at the
//! cap for `stall_time_s`); a joint that reaches the end of the overtravel freely has its
//! stop further out. Pure: the caller gives the time, the joint state and the torque.

use super::joints::{JointSettings, JointsError, Side, StopFound};
use crate::kinematics::JointLimits;
use crate::types::{JOINTS, JointState};

/// A stall needs the torque within this fraction of the cap (the PD saturates there).
const AT_CAP: f64 = 0.9;

/// What the caller does next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SearchStep {
    /// Hold the swept joint's setpoint here, rad (the others where they started).
    Drive { setpoint_rad: f64 },
    /// The sweep is over.
    Found(StopFound),
}

/// A sweep under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopSearch {
    pub joint: usize,
    pub side: Side,
    start_rad: f64,
    end_rad: f64,
    start_t_s: Option<f64>,
    stalled_since: Option<f64>,
    settings: JointSettings,
}

impl StopSearch {
    /// Sweep `joint` from `from_rad` toward its `side` stop.
    pub fn new(
        joint: usize,
        side: Side,
        from_rad: f64,
        limits: &JointLimits,
        settings: JointSettings,
    ) -> Result<Self, JointsError> {
        if joint >= JOINTS {
            return Err(JointsError::NoSuchJoint { joint });
        }
        if !from_rad.is_finite() {
            return Err(JointsError::NonFinite {
                joint,
                value: from_rad,
            });
        }
        let end_rad = side.limit(limits, joint) + side.sign() * settings.overtravel_rad;
        Ok(Self {
            joint,
            side,
            start_rad: from_rad,
            end_rad,
            start_t_s: None,
            stalled_since: None,
            settings,
        })
    }

    /// Where the sweep gives up looking, rad.
    pub fn end_rad(&self) -> f64 {
        self.end_rad
    }

    /// One servo cycle: the measured state and the torque the swept joint was given, N·m.
    pub fn step(&mut self, state: &JointState, torque_nm: f64) -> Result<SearchStep, JointsError> {
        let j = self.joint;
        let (q, qd) = (state.position_rad[j], state.velocity_rad_s[j]);
        if !(q.is_finite() && qd.is_finite() && torque_nm.is_finite() && state.t_s.is_finite()) {
            return Err(JointsError::NonFinite { joint: j, value: q });
        }
        let t0 = *self.start_t_s.get_or_insert(state.t_s);
        let sign = self.side.sign();
        if sign * (q - self.end_rad) >= 0.0 {
            return Ok(self.found(q, false));
        }
        let cap = self.settings.sweep_torque_nm[j];
        let pushing = sign * torque_nm >= AT_CAP * cap;
        if pushing && qd.abs() < self.settings.stall_speed_rad_s {
            let since = *self.stalled_since.get_or_insert(state.t_s);
            if state.t_s - since >= self.settings.stall_time_s {
                return Ok(self.found(q, true));
            }
        } else {
            self.stalled_since = None;
        }
        let travel = self.settings.sweep_speed_rad_s * (state.t_s - t0).max(0.0);
        let reach = (self.end_rad - self.start_rad).abs();
        let setpoint_rad = self.start_rad + sign * travel.min(reach);
        Ok(SearchStep::Drive { setpoint_rad })
    }

    fn found(&self, at_rad: f64, stalled: bool) -> SearchStep {
        SearchStep::Found(StopFound {
            joint: self.joint,
            side: self.side,
            at_rad,
            stalled,
        })
    }
}
