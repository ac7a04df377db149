//! Moving the sensor between tracker targets.
//!
//! A move is a straight line of the sensor centre in the tissue frame, from where the
//! setpoint begins to the target at the commanded contact height, timed by a trapezoidal
//! (acceleration-limited) profile that starts and ends at rest: the seed's robot stops to
//! sample. [`MotionPlanner::setpoint`] gives the position and velocity to command at a time
//! (turned into joint setpoints by [`crate::kinematics::ArmModel::joint_setpoint`]);
//! [`MotionPlanner::settled`] says when the tracker may sample again.
//!
//! Heights: the setpoint's `y` is `contact_height_m`, a few mm below the surface, so that
//! the low-gain PD and the tissue act as two springs pressing the sensor in. Settling is
//! judged over the surface only (`x`, `z`): the height is the tissue's business.

pub mod params;
mod profile;

use nalgebra::{Point3, Vector3};
use thiserror::Error;

pub use params::MotionParams;
pub use profile::{ProfileSample, Trapezoid};

use crate::frames::SurfacePoint;

#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum MotionError {
    #[error("invalid motion settings: {what}")]
    InvalidParams { what: &'static str },
    #[error("{what} is not finite")]
    NonFinite { what: &'static str },
    #[error("commanded speed {speed_m_s} m/s must be positive and finite")]
    InvalidSpeed { speed_m_s: f64 },
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Move {
    from: Point3<f64>,
    /// Unit vector from `from` to the end point; zero for a move of no length.
    direction: Vector3<f64>,
    profile: Trapezoid,
    start_s: f64,
    target: SurfacePoint,
}

impl Move {
    fn finish_s(&self) -> f64 {
        self.start_s + self.profile.duration_s()
    }
}

#[derive(Debug, Clone)]
pub struct MotionPlanner {
    params: MotionParams,
    current: Option<Move>,
}

fn finite_point(what: &'static str, p: &Point3<f64>) -> Result<(), MotionError> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(MotionError::NonFinite { what })
    }
}

fn finite_time(t_s: f64) -> Result<(), MotionError> {
    if t_s.is_finite() {
        Ok(())
    } else {
        Err(MotionError::NonFinite { what: "time" })
    }
}

impl MotionPlanner {
    /// A planner with nothing to do yet. Refuses settings that would divide by zero or
    /// produce NaN.
    pub fn new(params: MotionParams) -> Result<Self, MotionError> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let bad = |what| Err(MotionError::InvalidParams { what });
        if !positive(params.max_speed_m_s) {
            return bad("max_speed_m_s must be positive");
        }
        if !positive(params.accel_m_s2) {
            return bad("accel_m_s2 must be positive");
        }
        if !positive(params.settle_tolerance_m) {
            return bad("settle_tolerance_m must be positive");
        }
        if !positive(params.settle_speed_m_s) {
            return bad("settle_speed_m_s must be positive");
        }
        if !(params.settle_timeout_s.is_finite() && params.settle_timeout_s >= 0.0) {
            return bad("settle_timeout_s must not be negative");
        }
        if !params.contact_height_m.is_finite() {
            return bad("contact_height_m must be finite");
        }
        Ok(Self {
            params,
            current: None,
        })
    }

    pub fn params(&self) -> &MotionParams {
        &self.params
    }

    /// The sensor-centre point (tissue frame) at the contact height over `p`.
    pub fn contact_point(&self, p: &SurfacePoint) -> Point3<f64> {
        Point3::new(p.x_m, self.params.contact_height_m, p.z_m)
    }

    /// Move from `from` to `target` at `speed_m_s` (capped at `max_speed_m_s`), starting at
    /// `t_s`. `from` is normally where the setpoint is now, so that it does not jump. A move
    /// of no length is finished at once.
    pub fn start(
        &mut self,
        from: SurfacePoint,
        target: SurfacePoint,
        speed_m_s: f64,
        t_s: f64,
    ) -> Result<(), MotionError> {
        let from = self.contact_point(&from);
        self.start_from_point(from, target, speed_m_s, t_s)
    }

    /// As [`Self::start`], from any sensor-centre point (tissue frame), e.g. from above the
    /// surface to touch down: the line ends at the contact height over `target`.
    pub fn start_from_point(
        &mut self,
        from: Point3<f64>,
        target: SurfacePoint,
        speed_m_s: f64,
        t_s: f64,
    ) -> Result<(), MotionError> {
        finite_time(t_s)?;
        finite_point("move start", &from)?;
        if !target.is_finite() {
            return Err(MotionError::NonFinite {
                what: "move target",
            });
        }
        if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
            return Err(MotionError::InvalidSpeed { speed_m_s });
        }
        let to = self.contact_point(&target);
        let delta = to - from;
        let distance_m = delta.norm();
        if !distance_m.is_finite() {
            return Err(MotionError::NonFinite {
                what: "move length",
            });
        }
        let direction = if distance_m > 0.0 {
            delta / distance_m
        } else {
            Vector3::zeros()
        };
        let speed = speed_m_s.min(self.params.max_speed_m_s);
        self.current = Some(Move {
            from,
            direction,
            profile: Trapezoid::new(distance_m, speed, self.params.accel_m_s2),
            start_s: t_s,
            target,
        });
        Ok(())
    }

    /// Stay at the contact height over `at` from `t_s` on.
    pub fn hold(&mut self, at: SurfacePoint, t_s: f64) -> Result<(), MotionError> {
        let p = self.contact_point(&at);
        self.hold_point(p, t_s)
    }

    /// Stay exactly at `at` (any height) from `t_s` on: e.g. where the sensor is on enable.
    pub fn hold_point(&mut self, at: Point3<f64>, t_s: f64) -> Result<(), MotionError> {
        finite_time(t_s)?;
        finite_point("hold point", &at)?;
        self.current = Some(Move {
            from: at,
            direction: Vector3::zeros(),
            profile: Trapezoid::new(0.0, self.params.max_speed_m_s, self.params.accel_m_s2),
            start_s: t_s,
            target: SurfacePoint::new(at.x, at.z),
        });
        Ok(())
    }

    /// Forget the current move: no setpoint until the next start or hold.
    pub fn clear(&mut self) {
        self.current = None;
    }

    /// Where the current move or hold is going, over the surface.
    pub fn target(&self) -> Option<SurfacePoint> {
        self.current.map(|m| m.target)
    }

    /// When the current profile ends, s.
    pub fn finish_time_s(&self) -> Option<f64> {
        self.current.map(|m| m.finish_s())
    }

    /// The current profile's length, m, and peak speed, m/s.
    pub fn profile(&self) -> Option<Trapezoid> {
        self.current.map(|m| m.profile)
    }

    /// Sensor-centre position and velocity to command at `t_s` (tissue frame): `None` before
    /// any start or hold, or if `t_s` is not finite. Before the start time the setpoint
    /// waits at the start; after the end it rests at the end.
    pub fn setpoint(&self, t_s: f64) -> Option<(Point3<f64>, Vector3<f64>)> {
        let m = self.current?;
        if !t_s.is_finite() {
            return None;
        }
        let s = m.profile.sample(t_s - m.start_s);
        Some((m.from + m.direction * s.s_m, m.direction * s.speed_m_s))
    }

    /// The move has arrived: its profile has finished and the believed sensor centre is
    /// within `settle_tolerance_m` of the target (over the surface) and slower than
    /// `settle_speed_m_s`; or `settle_timeout_s` has passed since the profile finished (a
    /// low-gain PD against friction may never get within the tolerance). False with no
    /// move or with any non-finite input.
    pub fn settled(&self, believed: SurfacePoint, believed_speed_m_s: f64, t_s: f64) -> bool {
        let Some(m) = self.current else {
            return false;
        };
        if !(believed.is_finite() && believed_speed_m_s.is_finite() && t_s.is_finite()) {
            return false;
        }
        let finish = m.finish_s();
        if t_s < finish {
            return false;
        }
        let arrived = believed.distance_to(&m.target) <= self.params.settle_tolerance_m
            && believed_speed_m_s.abs() < self.params.settle_speed_m_s;
        arrived || t_s - finish >= self.params.settle_timeout_s
    }
}

#[cfg(test)]
#[path = "motion_tests.rs"]
mod tests;
