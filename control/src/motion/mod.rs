//! Moving the sensor between tracker targets.
//!
//! A move is a straight line of the sensor centre in the tissue frame, from where the
//! setpoint begins to the target at the commanded contact height, timed by a trapezoidal
//! (acceleration-limited) profile that starts and ends at rest: the seed's robot stops to
//! sample. [`MotionPlanner::setpoint`] gives the position and velocity to command at a time
//! (turned into joint setpoints by [`crate::kinematics::ArmModel::joint_setpoint`]);
//! [`MotionPlanner::arrival`] says whether the sensor has arrived (judged from the encoders,
//! never assumed from the setpoint), is still on its way, or stopped short and by how much;
//! [`MotionPlanner::settled`] (arrived) says when the tracker may sample again.
//! [`MotionPlanner::observe`] is what the loops call: it trims a stalled arm and *latches*
//! the first verdict of a move (arrived or stopped short), so that every move ends, once, at
//! most `settle_timeout_s` after its profile. An instantaneous judgement alone flickers at
//! rest (encoder speed spikes with each heartbeat) and a tracker waiting for an unbroken
//! stretch of arrival would wait for ever.
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

/// The setpoint's offset after a move's profile (see [`MotionPlanner::trim_toward_target`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Trim {
    x_m: f64,
    z_m: f64,
    /// When it was last updated, s.
    t_s: Option<f64>,
}

impl Trim {
    const ZERO: Trim = Trim {
        x_m: 0.0,
        z_m: 0.0,
        t_s: None,
    };
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
    trim: Trim,
    /// The current move's verdict once it is decided: `Arrived` or `StoppedShort`, kept
    /// until the next start, hold or clear.
    verdict: Option<Arrival>,
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
        if !(params.trim_rate_per_s.is_finite() && params.trim_rate_per_s >= 0.0) {
            return bad("trim_rate_per_s must not be negative");
        }
        if !(params.trim_max_m.is_finite() && params.trim_max_m >= 0.0) {
            return bad("trim_max_m must not be negative");
        }
        Ok(Self {
            params,
            current: None,
            trim: Trim::ZERO,
            verdict: None,
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
        if !target.is_finite() {
            return Err(MotionError::NonFinite {
                what: "move target",
            });
        }
        let to = self.contact_point(&target);
        self.start_to_point(from, to, speed_m_s, t_s)
    }

    /// A straight move between any two sensor-centre points (tissue frame), at any height:
    /// the tissue-frame calibration's lifts and slow descents onto the surface. Arrival is
    /// judged over the surface (`x`, `z`) as for every move.
    pub fn start_to_point(
        &mut self,
        from: Point3<f64>,
        to: Point3<f64>,
        speed_m_s: f64,
        t_s: f64,
    ) -> Result<(), MotionError> {
        finite_time(t_s)?;
        finite_point("move start", &from)?;
        finite_point("move target", &to)?;
        if !(speed_m_s.is_finite() && speed_m_s > 0.0) {
            return Err(MotionError::InvalidSpeed { speed_m_s });
        }
        let target = SurfacePoint::new(to.x, to.z);
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
        // `from` is where the setpoint is, trim included: the new profile takes it over.
        self.trim = Trim::ZERO;
        self.verdict = None;
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
        self.trim = Trim::ZERO;
        self.verdict = None;
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
        self.trim = Trim::ZERO;
        self.verdict = None;
    }

    /// What the loops call whenever the belief is refreshed (every servo cycle, or every
    /// frame): judges the move ([`Self::arrival`]) and, while it is undecided, trims a
    /// stalled arm ([`Self::trim_toward_target`]). The first `Arrived` or `StoppedShort` is
    /// the move's verdict and is returned from then on, whatever the arm does, until the
    /// next start, hold or clear: a move is decided at the latest `settle_timeout_s` after
    /// its profile, and once decided the trim stops moving the setpoint. Non-finite input
    /// is no observation (`Moving`, or the verdict already reached). No allocation.
    pub fn observe(
        &mut self,
        believed: SurfacePoint,
        believed_speed_m_s: f64,
        t_s: f64,
    ) -> Arrival {
        if let Some(v) = self.verdict {
            return v;
        }
        let a = self.arrival(believed, believed_speed_m_s, t_s);
        if a == Arrival::Moving {
            self.trim_toward_target(believed, believed_speed_m_s, t_s);
            return a;
        }
        self.verdict = Some(a);
        a
    }

    /// The current move's verdict as [`Self::observe`] last left it: `Moving` until it is
    /// decided, and with no move.
    pub fn verdict(&self) -> Arrival {
        self.verdict.unwrap_or(Arrival::Moving)
    }

    /// One step of the outer loop that makes a finished move arrive: while the believed
    /// sensor centre (encoders through the kinematics) is farther than `settle_tolerance_m`
    /// from the target, the setpoint is moved toward where the arm must go at
    /// `trim_rate_per_s` times the error, up to `trim_max_m`; within the tolerance it stays.
    /// Call it whenever the belief is refreshed (every servo cycle, or every frame); the
    /// time since the last call (at most 0.05 s counted) is the step. Does nothing during
    /// the profile, with no move, or with non-finite input. No allocation.
    pub fn trim_toward_target(
        &mut self,
        believed: SurfacePoint,
        believed_speed_m_s: f64,
        t_s: f64,
    ) {
        let Some(m) = self.current else {
            return;
        };
        if !(believed.is_finite() && believed_speed_m_s.is_finite() && t_s.is_finite())
            || t_s < m.finish_s()
        {
            return;
        }
        let dt = self
            .trim
            .t_s
            .map_or(0.0, |last| (t_s - last).clamp(0.0, 0.05));
        self.trim.t_s = Some(t_s);
        // Only a stalled arm is trimmed: one still coasting in gets there by itself.
        if believed_speed_m_s.abs() >= self.params.settle_speed_m_s {
            return;
        }
        let (ex, ez) = (m.target.x_m - believed.x_m, m.target.z_m - believed.z_m);
        if ex.hypot(ez) <= self.params.settle_tolerance_m {
            return;
        }
        let k = self.params.trim_rate_per_s * dt;
        let (x, z) = (self.trim.x_m + k * ex, self.trim.z_m + k * ez);
        let n = x.hypot(z);
        let scale = if n > self.params.trim_max_m {
            self.params.trim_max_m / n
        } else {
            1.0
        };
        self.trim.x_m = x * scale;
        self.trim.z_m = z * scale;
    }

    /// The setpoint's current trim over the surface, m (zero during a profile).
    pub fn trim(&self) -> SurfacePoint {
        SurfacePoint::new(self.trim.x_m, self.trim.z_m)
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
        let trim = Vector3::new(self.trim.x_m, 0.0, self.trim.z_m);
        Some((
            m.from + m.direction * s.s_m + trim,
            m.direction * s.speed_m_s,
        ))
    }

    /// Where the current move stands, judged from the *believed* sensor centre (the encoders
    /// through the kinematic model, never the setpoint) and its speed over the surface:
    ///
    /// - [`Arrival::Arrived`]: the profile has finished and the believed centre is within
    ///   `settle_tolerance_m` of the target (over the surface, the boundary included) and
    ///   slower than `settle_speed_m_s`;
    /// - [`Arrival::StoppedShort`]: `settle_timeout_s` has passed since the profile finished
    ///   and it has not arrived (a low-gain PD against friction or a heavy load), with the
    ///   distance still to go and why;
    /// - [`Arrival::Moving`] otherwise, also with no move and with any non-finite input
    ///   (nothing it could vouch for).
    ///
    /// A pure function of its inputs, the instantaneous judgement: at rest it can flicker
    /// between `Arrived` and `StoppedShort` as the measured speed crosses the threshold; the
    /// loops use [`Self::observe`], which keeps the first verdict. No allocation; a few
    /// flops (it runs every servo cycle).
    pub fn arrival(&self, believed: SurfacePoint, believed_speed_m_s: f64, t_s: f64) -> Arrival {
        let Some(m) = self.current else {
            return Arrival::Moving;
        };
        if !(believed.is_finite() && believed_speed_m_s.is_finite() && t_s.is_finite()) {
            return Arrival::Moving;
        }
        let finish = m.finish_s();
        if t_s < finish {
            return Arrival::Moving;
        }
        let to_go_m = believed.distance_to(&m.target);
        let close = to_go_m <= self.params.settle_tolerance_m;
        let at_rest = believed_speed_m_s.abs() < self.params.settle_speed_m_s;
        if close && at_rest {
            return Arrival::Arrived;
        }
        if t_s - finish < self.params.settle_timeout_s {
            return Arrival::Moving;
        }
        Arrival::StoppedShort(Shortfall {
            distance_m: to_go_m,
            reason: if at_rest {
                ShortfallReason::Stalled
            } else {
                ShortfallReason::NotAtRest
            },
        })
    }

    /// The move has really arrived ([`Self::arrival`] is [`Arrival::Arrived`]): what a
    /// tracker's `settled` means. False while moving, after a stop short of the target, with
    /// no move, and with any non-finite input.
    pub fn settled(&self, believed: SurfacePoint, believed_speed_m_s: f64, t_s: f64) -> bool {
        self.arrival(believed, believed_speed_m_s, t_s) == Arrival::Arrived
    }
}

/// Where a move stands (see [`MotionPlanner::arrival`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Arrival {
    /// Under way, or still within the settling time after the profile ended (or nothing to
    /// judge).
    Moving,
    /// The believed sensor centre is within the tolerance of the target and at rest.
    Arrived,
    /// The settling time is over and the arm is not there.
    StoppedShort(Shortfall),
}

/// How far short of its target a move ended, and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shortfall {
    /// Believed sensor centre to the target over the surface, m (more than the tolerance, or
    /// within it but not at rest).
    pub distance_m: f64,
    pub reason: ShortfallReason,
}

/// Why a move did not arrive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShortfallReason {
    /// At rest outside the tolerance: the drive cannot push further (joint or tissue
    /// friction, an uncompensated load).
    Stalled,
    /// Still moving faster than the settling speed after the settling time (oscillating,
    /// creeping, or pushed by something).
    NotAtRest,
}

impl ShortfallReason {
    /// snake_case, as JSON and end reasons spell it.
    pub fn as_str(&self) -> &'static str {
        match self {
            ShortfallReason::Stalled => "stalled",
            ShortfallReason::NotAtRest => "not_at_rest",
        }
    }

    /// In words for people.
    pub fn describe(&self) -> &'static str {
        match self {
            ShortfallReason::Stalled => {
                "came to rest short of it (friction or a load the drive cannot overcome)"
            }
            ShortfallReason::NotAtRest => "was still moving when the settling time ran out",
        }
    }
}

impl std::fmt::Display for Shortfall {
    /// For people: mm, with the reason.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the arm stopped {:.2} mm short of its target: it {}",
            self.distance_m * 1e3,
            self.reason.describe()
        )
    }
}

#[cfg(test)]
#[path = "motion_tests.rs"]
mod tests;
