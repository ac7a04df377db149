//! The rod through the fixed pivot (remote centre of motion): gimbal point G <-> rod tip T.
//!
//! The rod of length L is held at G and slides through the pivot P, so its axis always
//! passes through P:
//!
//! ```text
//! forward:  u = (P − G)/|P − G|,  T = G + L u,  depth d = L − |P − G|
//! inverse:  u = (T − P)/|T − P|,  G = T − L u,  depth d = |T − P|
//! ```
//!
//! A lateral tip move δ needs a gimbal move of about −(L − d)/d · δ ([`lever_ratio`]), which
//! blows up as the tip nears the pivot, so every guarded map refuses depths outside
//! `[min_depth_m, max_depth_m]`; the maximum keeps the gimbal clear of the pivot.

use nalgebra::{Matrix3, Point3, Unit, Vector3};

use super::error::KinematicsError;
use super::params::PivotGeometry;
use crate::frames::{Gimbal, Pivot, Tip};

/// Nearer than this to the pivot, the rod's direction is undefined.
pub const AT_PIVOT_TOLERANCE_M: f64 = 1e-9;

/// The rod as the gimbal point places it, before any depth guard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodPose {
    pub tip: Tip,
    /// Unit vector along the rod from the gimbal point through the pivot toward the tip.
    pub axis: Unit<Vector3<f64>>,
    /// Insertion depth L − |P − G|; negative if the tip is withdrawn above the pivot.
    pub depth_m: f64,
}

pub fn pivot_point(pivot: &PivotGeometry) -> Pivot {
    Pivot(Point3::from(pivot.pivot_in_base_m))
}

fn finite_point(what: &'static str, p: &Point3<f64>) -> Result<(), KinematicsError> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(KinematicsError::NonFinite { what })
    }
}

fn check_depth(pivot: &PivotGeometry, depth_m: f64) -> Result<(), KinematicsError> {
    if (pivot.min_depth_m..=pivot.max_depth_m).contains(&depth_m) {
        Ok(())
    } else {
        Err(KinematicsError::DepthOutOfRange {
            depth_m,
            min_m: pivot.min_depth_m,
            max_m: pivot.max_depth_m,
        })
    }
}

/// Where the rod ends for a gimbal point, with only the gimbal-on-pivot guard (no depth
/// range): for diagnostics and for a simulator that must place the rod wherever it is.
pub fn rod_pose(pivot: &PivotGeometry, gimbal: &Gimbal) -> Result<RodPose, KinematicsError> {
    finite_point("gimbal point", &gimbal.0)?;
    let w = pivot_point(pivot).0 - gimbal.0;
    let n = w.norm();
    if n < AT_PIVOT_TOLERANCE_M {
        return Err(KinematicsError::AtPivot {
            what: "gimbal point",
            distance_m: n,
        });
    }
    let axis = Unit::new_unchecked(w / n);
    Ok(RodPose {
        tip: Tip(gimbal.0 + pivot.rod_length_m * axis.into_inner()),
        axis,
        depth_m: pivot.rod_length_m - n,
    })
}

/// Forward map with every guard: the tip for a gimbal point whose depth lies in range.
pub fn tip_from_gimbal(pivot: &PivotGeometry, gimbal: &Gimbal) -> Result<Tip, KinematicsError> {
    let pose = rod_pose(pivot, gimbal)?;
    check_depth(pivot, pose.depth_m)?;
    Ok(pose.tip)
}

/// Inverse map with every guard: the gimbal point that puts the rod tip at `tip`.
pub fn gimbal_from_tip(pivot: &PivotGeometry, tip: &Tip) -> Result<Gimbal, KinematicsError> {
    finite_point("rod tip", &tip.0)?;
    let v = tip.0 - pivot_point(pivot).0;
    let d = v.norm();
    if d < AT_PIVOT_TOLERANCE_M {
        return Err(KinematicsError::AtPivot {
            what: "rod tip",
            distance_m: d,
        });
    }
    check_depth(pivot, d)?;
    Ok(Gimbal(tip.0 - pivot.rod_length_m * (v / d)))
}

/// Insertion depth for a gimbal point (no range guard).
pub fn depth_m(pivot: &PivotGeometry, gimbal: &Gimbal) -> Result<f64, KinematicsError> {
    rod_pose(pivot, gimbal).map(|p| p.depth_m)
}

/// d T / d G at a gimbal point in range: `I − (L/n)(I − û ûᵀ)` with n = |P − G|. Along the
/// rod the tip follows the gimbal one to one; across it the tip moves −(d/(L − d)) as much.
pub fn tip_jacobian(
    pivot: &PivotGeometry,
    gimbal: &Gimbal,
) -> Result<Matrix3<f64>, KinematicsError> {
    let pose = rod_pose(pivot, gimbal)?;
    check_depth(pivot, pose.depth_m)?;
    let n = pivot.rod_length_m - pose.depth_m;
    Ok(across_axis_scaled(&pose.axis, -pivot.rod_length_m / n))
}

/// d G / d T at a tip in range: `I − (L/d)(I − û ûᵀ)` with d = |T − P|.
pub fn gimbal_jacobian(pivot: &PivotGeometry, tip: &Tip) -> Result<Matrix3<f64>, KinematicsError> {
    gimbal_from_tip(pivot, tip)?;
    let v = tip.0 - pivot_point(pivot).0;
    let d = v.norm();
    Ok(across_axis_scaled(
        &Unit::new_unchecked(v / d),
        -pivot.rod_length_m / d,
    ))
}

/// `I + k (I − û ûᵀ)`: identity along `axis`, `1 + k` across it.
fn across_axis_scaled(axis: &Unit<Vector3<f64>>, k: f64) -> Matrix3<f64> {
    let u = axis.into_inner();
    let across = Matrix3::identity() - u * u.transpose();
    Matrix3::identity() + k * across
}

/// The lever: gimbal motion per unit lateral tip motion, (L − d)/d, at depth `depth_m`
/// (mirrored: the gimbal moves the other way). Refuses depths outside (0, L).
pub fn lever_ratio(pivot: &PivotGeometry, depth_m: f64) -> Result<f64, KinematicsError> {
    if !depth_m.is_finite() {
        return Err(KinematicsError::NonFinite { what: "depth" });
    }
    if !(depth_m > 0.0 && depth_m < pivot.rod_length_m) {
        return Err(KinematicsError::DepthOutOfRange {
            depth_m,
            min_m: 0.0,
            max_m: pivot.rod_length_m,
        });
    }
    Ok((pivot.rod_length_m - depth_m) / depth_m)
}

#[cfg(test)]
#[path = "pivot_tests.rs"]
mod tests;
