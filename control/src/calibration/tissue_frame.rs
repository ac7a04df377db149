//! The tissue frame from touched surface points: the surface plane (height and tilt) and, from
//! two points along the expected artery course, the yaw; the result is the kinematics'
//! [`TissuePlacement`].
//!
//! The plane is the total-least-squares fit (the centroid and the smallest principal axis of
//! the points' scatter), a 3 × 3 eigenproblem written here because its other two eigenvalues
//! are what tells collinear or coincident touches from a surface. The kinematics' tissue frame
//! is level (it shares the base's vertical), so the fitted tilt is reported and checked, not
//! put into the placement. Where the origin lies along the artery is a convention touches
//! cannot observe, so it is kept from the configured (prior) placement.

use std::f64::consts::FRAC_PI_3;

use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};
use thiserror::Error;

use super::tolerance::{Check, Tolerances};
use crate::frames::TissuePlacement;
use crate::kinematics::{ArmModel, KinematicsError};
use crate::types::Joints;

/// Touched points whose RMS spread about their centroid is below this along either of its two
/// widest directions are refused: a 0.1 mm touch error over 2 mm is already 3° of tilt.
pub const MIN_SPREAD_M: f64 = 2e-3;

/// The two artery points must be at least this far apart horizontally: a 0.2 mm touch error
/// over 10 mm is about 1° of yaw.
pub const MIN_ARTERY_SPAN_M: f64 = 0.01;

/// A surface steeper than this is refused: the frame is level, and the height under the
/// origin of a near-vertical plane means nothing.
pub const MAX_SURFACE_TILT_RAD: f64 = FRAC_PI_3;

/// Two touched points along the expected artery course, base frame, m; tissue `+x` runs from
/// `from` toward `to`. The line through them lies at tissue `z = lateral_m` (0 by the usual
/// convention, the artery along tissue `x`; a phantom's drawing may put it elsewhere).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArteryCourse {
    pub from: Point3<f64>,
    pub to: Point3<f64>,
    pub lateral_m: f64,
}

/// Where the fitted placement's yaw came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum YawSource {
    ArteryCourse,
    /// No artery course given: the configured yaw is kept.
    Prior,
}

#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum TissueFrameError {
    #[error("need at least 3 touched surface points to fit a plane, got {points}")]
    TooFewPoints { points: usize },

    #[error("{what} {index} is not finite")]
    NonFinite { what: &'static str, index: usize },

    #[error("the fit overflowed: the touched points' coordinates are too large for it")]
    Overflow,

    #[error("the configured (prior) tissue placement is not finite")]
    NonFinitePrior,

    #[error(
        "the touched points coincide: RMS spread {spread_m:.3e} m about their centroid, need \
         {min_m:.1e} m; touch points across the patch"
    )]
    Coincident { spread_m: f64, min_m: f64 },

    #[error(
        "the touched points are collinear: RMS spread {width_m:.3e} m across their line, need \
         {min_m:.1e} m; touch at least one point off the line"
    )]
    Collinear { width_m: f64, min_m: f64 },

    #[error(
        "the touched points lie on a surface tilted {tilt_rad:.3} rad from level (at most \
         {max_rad:.3} rad): not a tissue surface under the arm"
    )]
    TooSteep { tilt_rad: f64, max_rad: f64 },

    #[error(
        "the artery points are {span_m:.3e} m apart horizontally, need {min_m:.1e} m to fix \
         the yaw"
    )]
    ArteryTooShort { span_m: f64, min_m: f64 },
}

/// The fitted tissue frame and how well the touches fit a level plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TissueFit {
    pub placement: TissuePlacement,
    /// Upward unit normal of the fitted plane, base frame.
    pub normal_in_base: Vector3<f64>,
    /// Angle of the normal from the vertical, rad.
    pub tilt_rad: f64,
    /// RMS distance of the touched points from the plane, m (0 by construction with 3 points).
    pub rms_residual_m: f64,
    /// Largest distance of a touched point from the plane, m, and that point's index.
    pub max_residual_m: f64,
    pub worst_point: usize,
    pub yaw_from: YawSource,
    pub points: usize,
}

impl TissueFit {
    /// The plane residual and the tilt against their tolerances.
    pub fn checks(&self, tolerances: &Tolerances) -> [Check; 2] {
        [
            Check::at_most(
                "tissue plane RMS residual",
                self.rms_residual_m,
                tolerances.tissue_max_rms_residual_m,
                "m",
            ),
            Check::at_most(
                "tissue surface tilt",
                self.tilt_rad,
                tolerances.tissue_max_tilt_rad,
                "rad",
            ),
        ]
    }
}

/// The sensor centre in the base frame at joints `q`, for recording a touch. Exact when the
/// sensor offset is vertical (the default); otherwise the offset is turned by the model's
/// configured yaw.
pub fn touched_point_in_base(model: &ArmModel, q: &Joints) -> Result<Point3<f64>, KinematicsError> {
    Ok(model.placement().to_base(&model.sensor_from_joints(q)?))
}

fn finite(p: &Point3<f64>) -> bool {
    p.iter().all(|v| v.is_finite())
}

/// Fit the tissue frame to touched `surface` points (base frame), taking the yaw from `artery`
/// if given and otherwise from `prior`, and the origin's horizontal position from `prior`
/// (moved onto the artery line if one is given).
pub fn fit_tissue_frame(
    surface: &[Point3<f64>],
    artery: Option<&ArteryCourse>,
    prior: &TissuePlacement,
) -> Result<TissueFit, TissueFrameError> {
    if surface.len() < 3 {
        return Err(TissueFrameError::TooFewPoints {
            points: surface.len(),
        });
    }
    if let Some(index) = surface.iter().position(|p| !finite(p)) {
        return Err(TissueFrameError::NonFinite {
            what: "surface point",
            index,
        });
    }
    if let Some(a) = artery
        && let Some(index) = [a.from, a.to]
            .iter()
            .position(|p| !finite(p))
            .or((!a.lateral_m.is_finite()).then_some(0))
    {
        return Err(TissueFrameError::NonFinite {
            what: "artery point",
            index,
        });
    }
    if !(prior.origin_in_base_m.iter().all(|v| v.is_finite()) && prior.yaw_rad.is_finite()) {
        return Err(TissueFrameError::NonFinitePrior);
    }

    let n = surface.len() as f64;
    let centroid = surface
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.coords)
        / n;
    let scatter = surface.iter().fold(Matrix3::zeros(), |acc, p| {
        let d = p.coords - centroid;
        acc + d * d.transpose()
    });
    if !scatter.iter().all(|v| v.is_finite()) {
        return Err(TissueFrameError::Overflow);
    }
    let eigen = SymmetricEigen::new(scatter);
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| eigen.eigenvalues[i].total_cmp(&eigen.eigenvalues[j]));
    let rms_along = |k: usize| (eigen.eigenvalues[order[k]].max(0.0) / n).sqrt();
    if rms_along(2) < MIN_SPREAD_M {
        return Err(TissueFrameError::Coincident {
            spread_m: rms_along(2),
            min_m: MIN_SPREAD_M,
        });
    }
    if rms_along(1) < MIN_SPREAD_M {
        return Err(TissueFrameError::Collinear {
            width_m: rms_along(1),
            min_m: MIN_SPREAD_M,
        });
    }
    let mut normal: Vector3<f64> = eigen.eigenvectors.column(order[0]).normalize();
    if normal.y < 0.0 {
        normal = -normal;
    }
    let tilt_rad = normal.y.clamp(-1.0, 1.0).acos();
    if tilt_rad > MAX_SURFACE_TILT_RAD {
        return Err(TissueFrameError::TooSteep {
            tilt_rad,
            max_rad: MAX_SURFACE_TILT_RAD,
        });
    }

    let (mut sum_sq, mut max_residual_m, mut worst_point) = (0.0, 0.0, 0);
    for (i, p) in surface.iter().enumerate() {
        let d = normal.dot(&(p.coords - centroid)).abs();
        sum_sq += d * d;
        if d > max_residual_m {
            max_residual_m = d;
            worst_point = i;
        }
    }

    let [ox, _, oz] = prior.origin_in_base_m;
    let (yaw_rad, (ox, oz), yaw_from) = match artery {
        None => (prior.yaw_rad, (ox, oz), YawSource::Prior),
        Some(a) => {
            let (dx, dz) = (a.to.x - a.from.x, a.to.z - a.from.z);
            let span_m = dx.hypot(dz);
            if span_m < MIN_ARTERY_SPAN_M {
                return Err(TissueFrameError::ArteryTooShort {
                    span_m,
                    min_m: MIN_ARTERY_SPAN_M,
                });
            }
            let (ex, ez) = (dx / span_m, dz / span_m);
            let along = (ox - a.from.x) * ex + (oz - a.from.z) * ez;
            // Tissue x turned by the yaw about +y is (cos ψ, 0, −sin ψ) = (ex, 0, ez), tissue
            // z is (sin ψ, 0, cos ψ) = (−ez, 0, ex): the origin lies `lateral_m` to −z of the
            // line.
            (
                (-dz).atan2(dx),
                (
                    a.from.x + along * ex + a.lateral_m * ez,
                    a.from.z + along * ez - a.lateral_m * ex,
                ),
                YawSource::ArteryCourse,
            )
        }
    };
    // The plane's height under the origin: n · (o − c) = 0 solved for o.y (n.y ≥ cos 60°).
    let oy = centroid.y - (normal.x * (ox - centroid.x) + normal.z * (oz - centroid.z)) / normal.y;
    if !([ox, oy, oz].iter().all(|v| v.is_finite()) && sum_sq.is_finite()) {
        return Err(TissueFrameError::Overflow);
    }
    Ok(TissueFit {
        placement: TissuePlacement {
            origin_in_base_m: [ox, oy, oz],
            yaw_rad,
        },
        normal_in_base: normal,
        tilt_rad,
        rms_residual_m: (sum_sq / n).sqrt(),
        max_residual_m,
        worst_point,
        yaw_from,
        points: surface.len(),
    })
}

#[cfg(test)]
#[path = "tissue_frame_tests.rs"]
mod tests;
