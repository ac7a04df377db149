//! The joints' calibration (docs/rig-bring-up.md section 1): the encoder zero from the
//! homing (the arm in its reset pose, whose joint angles the config knows), and the
//! mechanical stops, found by a slow torque-limited sweep ([`super::stop_search`]), judged
//! against the configured software limits. Pure arithmetic on what was read.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::tolerance::Check;
use crate::kinematics::JointLimits;
use crate::types::{JOINTS, Joints};

/// The procedure's pose, speeds, torques and pass limits (config `calibration.joints`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointSettings {
    /// Joint angles of the reset pose (the arm against its reset fixture), rad.
    pub reset_pose_rad: Joints,
    /// Largest zero offset (reset pose against what the encoders read there) that passes,
    /// rad: more is a wrong fixture or a slipped capstan, not a calibration.
    pub max_zero_offset_rad: f64,
    /// Speed of the sweep toward a stop, rad/s.
    pub sweep_speed_rad_s: f64,
    /// The most torque the sweep puts on each joint, N·m: enough to overcome friction and
    /// the arm's weight, little enough that meeting a stop harms nothing.
    pub sweep_torque_nm: Joints,
    /// How far beyond the software limit the sweep goes looking for the stop, rad.
    pub overtravel_rad: f64,
    /// The software limit must lie at least this far inside its mechanical stop, rad.
    pub min_stop_margin_rad: f64,
    /// A joint slower than this, with its torque at the limit, is stalled, rad/s.
    pub stall_speed_rad_s: f64,
    /// ... for this long: then it is at its stop, s.
    pub stall_time_s: f64,
}

impl Default for JointSettings {
    fn default() -> Self {
        Self {
            // The Phantom Premium's reset pose: links square, the gimbal arm level.
            reset_pose_rad: [0.0, 0.0, 0.0],
            max_zero_offset_rad: 0.1,
            sweep_speed_rad_s: 0.1,
            sweep_torque_nm: [0.15, 0.15, 0.15],
            overtravel_rad: 0.1,
            min_stop_margin_rad: 0.02,
            stall_speed_rad_s: 0.01,
            stall_time_s: 0.2,
        }
    }
}

impl JointSettings {
    /// Refuse settings no sweep could run or be judged by.
    pub fn check(&self) -> Result<(), String> {
        if let Some(v) = self.reset_pose_rad.iter().find(|v| !v.is_finite()) {
            return Err(format!("reset_pose_rad must be finite, got {v}"));
        }
        let positive = [
            ("max_zero_offset_rad", self.max_zero_offset_rad),
            ("sweep_speed_rad_s", self.sweep_speed_rad_s),
            ("overtravel_rad", self.overtravel_rad),
            ("min_stop_margin_rad", self.min_stop_margin_rad),
            ("stall_speed_rad_s", self.stall_speed_rad_s),
            ("stall_time_s", self.stall_time_s),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be positive and finite, got {v}"));
            }
        }
        if let Some(v) = self
            .sweep_torque_nm
            .iter()
            .find(|v| !(v.is_finite() && **v > 0.0))
        {
            return Err(format!(
                "sweep_torque_nm must be positive and finite, got {v}"
            ));
        }
        if self.sweep_speed_rad_s > 0.5 {
            return Err(format!(
                "sweep_speed_rad_s must be slow (at most 0.5 rad/s), got {}",
                self.sweep_speed_rad_s
            ));
        }
        if self.overtravel_rad < self.min_stop_margin_rad {
            return Err(format!(
                "overtravel_rad ({}) must reach min_stop_margin_rad ({}): a sweep stopped \
                 short of the margin could never pass",
                self.overtravel_rad, self.min_stop_margin_rad
            ));
        }
        Ok(())
    }
}

/// Which end of a joint's travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Lower,
    Upper,
}

impl Side {
    pub fn name(self) -> &'static str {
        match self {
            Side::Lower => "lower",
            Side::Upper => "upper",
        }
    }

    /// −1 toward the lower stop, +1 toward the upper.
    pub fn sign(self) -> f64 {
        match self {
            Side::Lower => -1.0,
            Side::Upper => 1.0,
        }
    }

    /// The software limit on this side.
    pub fn limit(self, limits: &JointLimits, joint: usize) -> f64 {
        match self {
            Side::Lower => limits.min_rad[joint],
            Side::Upper => limits.max_rad[joint],
        }
    }
}

#[derive(Debug, Clone, PartialEq, Error)]
pub enum JointsError {
    #[error("joint {joint} read a non-finite angle ({value})")]
    NonFinite { joint: usize, value: f64 },
    #[error("there is no joint {joint} (the Phantom has joints 0, 1 and 2)")]
    NoSuchJoint { joint: usize },
}

/// The zero offset of each joint: what to add to the encoders' angles so that the reset
/// pose reads as its known angles (`reset − read`), rad.
pub fn zero_offsets(reset_pose_rad: &Joints, read_rad: &Joints) -> Result<Joints, JointsError> {
    let mut offset = [0.0; JOINTS];
    for j in 0..JOINTS {
        if !read_rad[j].is_finite() {
            return Err(JointsError::NonFinite {
                joint: j,
                value: read_rad[j],
            });
        }
        offset[j] = reset_pose_rad[j] - read_rad[j];
    }
    Ok(offset)
}

/// The encoders' angles as the homing corrected them: each joint's zero offset added (every
/// servo cycle, so measured in the cycle bench: docs/BENCHMARKS.md).
#[inline]
pub fn through_zero(position_rad: &mut Joints, zero_offset_rad: &Joints) {
    for (q, o) in position_rad.iter_mut().zip(zero_offset_rad) {
        *q += o;
    }
}

const ZERO_NAMES: [&str; JOINTS] = [
    "joint 0 zero offset (magnitude)",
    "joint 1 zero offset (magnitude)",
    "joint 2 zero offset (magnitude)",
];

const STOP_NAMES: [[&str; 2]; JOINTS] = [
    [
        "joint 0 lower stop beyond its software limit",
        "joint 0 upper stop beyond its software limit",
    ],
    [
        "joint 1 lower stop beyond its software limit",
        "joint 1 upper stop beyond its software limit",
    ],
    [
        "joint 2 lower stop beyond its software limit",
        "joint 2 upper stop beyond its software limit",
    ],
];

/// Each joint's offset against `max_zero_offset_rad`.
pub fn zero_checks(offset_rad: &Joints, settings: &JointSettings) -> Vec<Check> {
    offset_rad
        .iter()
        .zip(ZERO_NAMES)
        .map(|(o, name)| Check::at_most(name, o.abs(), settings.max_zero_offset_rad, "rad"))
        .collect()
}

/// Where a sweep found a joint's stop (or where it gave up looking).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StopFound {
    pub joint: usize,
    pub side: Side,
    /// The joint's angle at the stop, or at the end of the overtravel, rad.
    pub at_rad: f64,
    /// True: the joint stalled there against the torque limit (a stop); false: it reached
    /// the end of the overtravel freely (the stop lies further out still).
    pub stalled: bool,
}

impl StopFound {
    /// How far the stop lies beyond the software limit (negative: inside it), rad; a
    /// sweep that met nothing counts its whole travel beyond the limit.
    pub fn margin_rad(&self, limits: &JointLimits) -> f64 {
        self.side.sign() * (self.at_rad - self.side.limit(limits, self.joint))
    }

    /// The margin against `min_stop_margin_rad`, named by joint and side.
    pub fn check(
        &self,
        limits: &JointLimits,
        settings: &JointSettings,
    ) -> Result<Check, JointsError> {
        let names = STOP_NAMES
            .get(self.joint)
            .ok_or(JointsError::NoSuchJoint { joint: self.joint })?;
        let name = names[usize::from(self.side == Side::Upper)];
        Ok(Check::at_least(
            name,
            self.margin_rad(limits),
            settings.min_stop_margin_rad,
            "rad",
        ))
    }
}
