//! Phantom Premium 1.5: joints <-> gimbal point G in the robot base frame.
//!
//! θ1 is the base yaw, θ2 the upper arm's elevation above horizontal and θ3 the forearm's
//! angle from the downward vertical, measured absolutely (not relative to θ2) because a
//! parallel drive turns the forearm. With `y` up (Cavusoglu et al. form):
//!
//! ```text
//! x = sin θ1 (l1 cos θ2 + l2 sin θ3)
//! y = l2 − l2 cos θ3 + l1 sin θ2
//! z = −l1 + cos θ1 (l1 cos θ2 + l2 sin θ3)
//! ```
//!
//! The shoulder axis is at `(0, l2, −l1)`; in the vertical plane through it the arm is a
//! planar two-link chain reaching `(r, h) = (√(x² + (z + l1)²), y − l2)` with absolute link
//! angles α = θ2 and β = θ3 − π/2. The inverse takes the Phantom's *elbow-up* branch: the
//! forearm turns clockwise from the upper arm (β − α = −γ, γ ∈ [0, π]), so the elbow sits
//! above the shoulder–gimbal line, as on the real arm (at home, θ = 0, the upper arm is
//! horizontal and the forearm hangs straight down). On that branch θ3 − θ2 = π/2 − γ, which
//! is π/2 at full stretch and −π/2 folded flat.

use nalgebra::{Matrix3, Point3};

use super::error::KinematicsError;
use super::params::{JointLimits, PhantomGeometry};
use crate::frames::Gimbal;
use crate::types::Joints;

/// A gimbal point beyond the stretched (or inside the folded) arm by at most this much is
/// taken as on the boundary; farther is out of reach.
pub const REACH_TOLERANCE_M: f64 = 1e-9;

/// Closer than this to the base yaw axis (or, with l1 = l2, to the shoulder) the base angle
/// is undefined.
pub const AXIS_TOLERANCE_M: f64 = 1e-9;

fn check_finite(what: &'static str, q: &Joints) -> Result<(), KinematicsError> {
    if q.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(KinematicsError::NonFinite { what })
    }
}

/// The distances from the shoulder axis the gimbal point can take: `|l1 − l2|..l1 + l2`.
pub fn reach_m(geom: &PhantomGeometry) -> (f64, f64) {
    ((geom.l1_m - geom.l2_m).abs(), geom.l1_m + geom.l2_m)
}

/// Forward kinematics: the gimbal point for joint angles `q`.
pub fn forward(geom: &PhantomGeometry, q: &Joints) -> Result<Gimbal, KinematicsError> {
    check_finite("joint angles", q)?;
    let (s1, c1) = q[0].sin_cos();
    let (s2, c2) = q[1].sin_cos();
    let (s3, c3) = q[2].sin_cos();
    let r = geom.l1_m * c2 + geom.l2_m * s3;
    Ok(Gimbal(Point3::new(
        s1 * r,
        geom.l2_m - geom.l2_m * c3 + geom.l1_m * s2,
        -geom.l1_m + c1 * r,
    )))
}

/// Analytic Jacobian d G / d q (rows x, y, z; columns θ1, θ2, θ3), m/rad.
pub fn jacobian(geom: &PhantomGeometry, q: &Joints) -> Result<Matrix3<f64>, KinematicsError> {
    check_finite("joint angles", q)?;
    let (l1, l2) = (geom.l1_m, geom.l2_m);
    let (s1, c1) = q[0].sin_cos();
    let (s2, c2) = q[1].sin_cos();
    let (s3, c3) = q[2].sin_cos();
    let r = l1 * c2 + l2 * s3;
    #[rustfmt::skip]
    let j = Matrix3::new(
        c1 * r,  -s1 * l1 * s2, s1 * l2 * c3,
        0.0,      l1 * c2,      l2 * s3,
        -s1 * r, -c1 * l1 * s2, c1 * l2 * c3,
    );
    Ok(j)
}

/// Inverse kinematics on the elbow-up branch (see the module notes). Joint limits are not
/// applied here; see [`check_limits`].
pub fn inverse(geom: &PhantomGeometry, gimbal: &Gimbal) -> Result<Joints, KinematicsError> {
    let g = gimbal.0;
    if !(g.x.is_finite() && g.y.is_finite() && g.z.is_finite()) {
        return Err(KinematicsError::NonFinite {
            what: "gimbal point",
        });
    }
    let (l1, l2) = (geom.l1_m, geom.l2_m);
    let zs = g.z + l1;
    let r = g.x.hypot(zs);
    if r < AXIS_TOLERANCE_M {
        return Err(KinematicsError::Singular {
            what: "gimbal point on the base yaw axis",
        });
    }
    let h = g.y - l2;
    let d = r.hypot(h);
    let (min_m, max_m) = reach_m(geom);
    if d > max_m + REACH_TOLERANCE_M || d < min_m - REACH_TOLERANCE_M {
        return Err(KinematicsError::OutOfReach {
            distance_m: d,
            min_m,
            max_m,
        });
    }
    if d < AXIS_TOLERANCE_M {
        return Err(KinematicsError::Singular {
            what: "gimbal point on the shoulder axis",
        });
    }
    // Elbow angle γ by the half-angle form: tan²(γ/2) = ((l1+l2)² − d²) / (d² − (l1−l2)²).
    // Written as products of differences it stays accurate near full stretch and fully
    // folded, where acos of the law of cosines loses half the digits. Values a hair past the
    // boundary (inside the tolerance) clamp to it.
    let stretch = ((max_m - d) * (max_m + d)).max(0.0);
    let fold = ((d - min_m) * (d + min_m)).max(0.0);
    let gamma = 2.0 * stretch.sqrt().atan2(fold.sqrt());
    let (sg, cg) = gamma.sin_cos();
    let alpha = h.atan2(r) + (l2 * sg).atan2(l1 + l2 * cg);
    let q = [
        g.x.atan2(zs),
        alpha,
        alpha - gamma + std::f64::consts::FRAC_PI_2,
    ];
    check_finite("inverse kinematics result", &q)?;
    Ok(q)
}

/// Refuse joint angles outside their ranges or outside the θ3 − θ2 coupling range.
pub fn check_limits(limits: &JointLimits, q: &Joints) -> Result<(), KinematicsError> {
    check_finite("joint angles", q)?;
    for (joint, &value_rad) in q.iter().enumerate() {
        let (min_rad, max_rad) = (limits.min_rad[joint], limits.max_rad[joint]);
        if !(min_rad..=max_rad).contains(&value_rad) {
            return Err(KinematicsError::JointLimit {
                joint,
                value_rad,
                min_rad,
                max_rad,
            });
        }
    }
    let coupling = q[2] - q[1];
    if !(limits.coupling_min_rad..=limits.coupling_max_rad).contains(&coupling) {
        return Err(KinematicsError::CouplingLimit {
            value_rad: coupling,
            min_rad: limits.coupling_min_rad,
            max_rad: limits.coupling_max_rad,
        });
    }
    Ok(())
}

/// The smallest distance, rad, from `q` to any joint or coupling limit (negative outside).
/// Used to judge how much room a placement leaves.
pub fn limit_margin_rad(limits: &JointLimits, q: &Joints) -> f64 {
    let mut margin = f64::INFINITY;
    for (i, &v) in q.iter().enumerate() {
        margin = margin.min(v - limits.min_rad[i]).min(limits.max_rad[i] - v);
    }
    let c = q[2] - q[1];
    margin
        .min(c - limits.coupling_min_rad)
        .min(limits.coupling_max_rad - c)
}

#[cfg(test)]
#[path = "phantom_tests.rs"]
mod tests;
