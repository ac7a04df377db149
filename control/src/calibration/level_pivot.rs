//! The pivot's horizontal place from touches on a level surface: a pivot `d` off to the side
//! tilts the rod the kinematics believe against the true one by an angle that grows with
//! the rod's tilt, so touches on a level plate appear to lie on a plane tilted by about
//! `(L / a) · d / (L − a)` (`a` gimbal to pivot, `L − a` pivot to tip; 2.4° for 5 mm on the
//! seed's rig). Fitting the pivot that makes the touches level recovers it.
//!
//! Gauss-Newton over three unknowns (the pivot's `x` and `z` offset and the plate's height)
//! with a numerical Jacobian through the kinematics: a few iterations from zero, written
//! here because it is ten lines over `ArmModel`. The pivot's height is not observable this
//! way (it moves every touch by nearly the same height, which the plate's height takes), so
//! it is kept. It assumes the plate is level: a plate tilted by ε reads as a pivot off by
//! about `ε · a (L − a) / L`, 0.1 mm per 0.05°; level it with a spirit level first.

use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};
use thiserror::Error;

use super::tolerance::{Check, Tolerances};
use crate::kinematics::{ArmModel, KinematicsError, PivotGeometry};

/// Fewest touches: three unknowns, and a residual to judge them by.
pub const MIN_TOUCHES: usize = 5;

/// Least RMS spread of the touches across their widest direction on the plate, m: touches
/// along one line see the pivot's offset only along that line. 10 mm over the seed's patch
/// (±140 mm) is a narrow strip still; the standard errors judge the rest.
pub const MIN_LAYOUT_SPREAD_M: f64 = 0.01;

/// The normal matrix's condition above which the touches do not fix the pivot both ways
/// (all along one line, or all under the pivot).
const MAX_CONDITION: f64 = 1e10;

#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum LevelPivotError {
    #[error("need at least {MIN_TOUCHES} touches on the level plate, got {touches}")]
    TooFewTouches { touches: usize },
    #[error("touch {index} is not finite")]
    NonFinite { index: usize },
    #[error("touch {index}: {source}")]
    Kinematics {
        index: usize,
        source: KinematicsError,
    },
    #[error(
        "the touch points lie along one line ({:.1} mm RMS across it, at least {:.0} mm): \
         spread them over the plate in x and in z",
        across_m * 1e3,
        MIN_LAYOUT_SPREAD_M * 1e3
    )]
    Collinear { across_m: f64 },
    #[error(
        "the touches do not fix the pivot both ways (condition {condition:.1e}): touch points \
         spread across the plate in x and in z"
    )]
    Degenerate { condition: f64 },
    #[error("the fit did not settle in {iterations} iterations")]
    NoConvergence { iterations: usize },
}

/// The fitted pivot and how well the touches fix it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelPivotFit {
    /// The configured pivot moved by the fitted offset, base frame, m.
    pub pivot_in_base_m: [f64; 3],
    /// The offset from the configured pivot, base `x` and `z`, m.
    pub offset_m: [f64; 2],
    /// Standard error of each, m.
    pub standard_error_m: [f64; 2],
    /// The plate's height, base frame, m.
    pub plate_height_m: f64,
    /// RMS and largest height residual of the touches about the level plate, m.
    pub rms_residual_m: f64,
    pub max_residual_m: f64,
    pub touches: usize,
}

impl LevelPivotFit {
    pub fn apply_to(&self, geometry: &PivotGeometry) -> PivotGeometry {
        PivotGeometry {
            pivot_in_base_m: self.pivot_in_base_m,
            ..*geometry
        }
    }

    /// The residual and the worse standard error against the pivot's residual tolerance.
    pub fn checks(&self, tolerances: &Tolerances) -> [Check; 2] {
        [
            Check::at_most(
                "level plate RMS residual",
                self.rms_residual_m,
                tolerances.pivot_max_rms_residual_m,
                "m",
            ),
            Check::at_most(
                "pivot standard error",
                self.standard_error_m[0].max(self.standard_error_m[1]),
                tolerances.pivot_max_rms_residual_m,
                "m",
            ),
        ]
    }
}

/// Refuse touch points (`[x, z]` on the plate) that lie along one line: their RMS spread
/// across their widest direction must be at least [`MIN_LAYOUT_SPREAD_M`]. Checked before
/// the arm moves (the daemon's procedure) and again by the fit.
pub fn check_layout(points_xz: &[[f64; 2]]) -> Result<(), LevelPivotError> {
    if points_xz.len() < MIN_TOUCHES {
        return Err(LevelPivotError::TooFewTouches {
            touches: points_xz.len(),
        });
    }
    if let Some(index) = points_xz
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(LevelPivotError::NonFinite { index });
    }
    let n = points_xz.len() as f64;
    let mean = |i: usize| points_xz.iter().map(|p| p[i]).sum::<f64>() / n;
    let (mx, mz) = (mean(0), mean(1));
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for p in points_xz {
        let (dx, dz) = (p[0] - mx, p[1] - mz);
        a += dx * dx / n;
        b += dx * dz / n;
        c += dz * dz / n;
    }
    // The smaller eigenvalue of the 2 × 2 scatter: the mean square across the widest line.
    let across2 = (a + c) / 2.0 - (((a - c) / 2.0).powi(2) + b * b).sqrt();
    let across_m = across2.max(0.0).sqrt();
    if across_m < MIN_LAYOUT_SPREAD_M {
        return Err(LevelPivotError::Collinear { across_m });
    }
    Ok(())
}

/// Heights of the touches (base frame) through `model` with its pivot moved by `dx`, `dz`.
fn heights(
    model: &ArmModel,
    q: &[[f64; 3]],
    dx: f64,
    dz: f64,
) -> Result<Vec<f64>, (usize, KinematicsError)> {
    let mut pivot = *model.pivot();
    pivot.pivot_in_base_m[0] += dx;
    pivot.pivot_in_base_m[2] += dz;
    let moved = model.with_pivot(pivot).map_err(|e| (0, e))?;
    q.iter()
        .enumerate()
        .map(|(i, q)| {
            moved
                .sensor_from_joints(q)
                .map(|p| moved.placement().to_base(&p).y)
                .map_err(|e| (i, e))
        })
        .collect()
}

/// The pivot that makes `touched` (sensor centres at each touch, tissue frame, as `model`
/// believed them) lie on a level plate.
pub fn fit_pivot_level(
    model: &ArmModel,
    touched: &[Point3<f64>],
) -> Result<LevelPivotFit, LevelPivotError> {
    let n = touched.len();
    if n < MIN_TOUCHES {
        return Err(LevelPivotError::TooFewTouches { touches: n });
    }
    if let Some(index) = touched
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(LevelPivotError::NonFinite { index });
    }
    let q: Vec<[f64; 3]> = touched
        .iter()
        .enumerate()
        .map(|(index, p)| {
            model
                .joints_for_sensor(p)
                .map_err(|source| LevelPivotError::Kinematics { index, source })
        })
        .collect::<Result<_, _>>()?;
    let layout: Vec<[f64; 2]> = touched.iter().map(|p| [p.x, p.z]).collect();
    check_layout(&layout)?;
    let kin = |(index, source)| LevelPivotError::Kinematics { index, source };
    let step = 1e-6;
    let (mut dx, mut dz) = (0.0, 0.0);
    let mut h = heights(model, &q, 0.0, 0.0).map_err(kin)?;
    let mut plate = h.iter().sum::<f64>() / n as f64;
    const ITERATIONS: usize = 20;
    for iteration in 0..=ITERATIONS {
        let hx = heights(model, &q, dx + step, dz).map_err(kin)?;
        let hz = heights(model, &q, dx, dz + step).map_err(kin)?;
        // Residual r = h − plate; Jacobian columns ∂r/∂dx, ∂r/∂dz, ∂r/∂plate = −1.
        let (mut jtj, mut jtr) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
        for i in 0..n {
            let row = Vector3::new((hx[i] - h[i]) / step, (hz[i] - h[i]) / step, -1.0);
            jtj += row * row.transpose();
            jtr += row * (h[i] - plate);
        }
        let eigen = SymmetricEigen::new(jtj);
        let (lo, hi) = eigen
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &e| {
                (lo.min(e), hi.max(e))
            });
        let condition = hi / lo;
        if lo.is_nan() || lo <= 0.0 || condition > MAX_CONDITION {
            return Err(LevelPivotError::Degenerate { condition });
        }
        let Some(inverse) = jtj.try_inverse() else {
            return Err(LevelPivotError::Degenerate { condition });
        };
        let delta = -(inverse * jtr);
        if delta.x.abs().max(delta.y.abs()) < 1e-10 || iteration == ITERATIONS {
            if iteration == ITERATIONS && delta.x.abs().max(delta.y.abs()) >= 1e-10 {
                return Err(LevelPivotError::NoConvergence {
                    iterations: ITERATIONS,
                });
            }
            let residuals: Vec<f64> = h.iter().map(|v| v - plate).collect();
            let rss: f64 = residuals.iter().map(|r| r * r).sum();
            let sigma2 = rss / (n as f64 - 3.0);
            let [px, py, pz] = model.pivot().pivot_in_base_m;
            return Ok(LevelPivotFit {
                pivot_in_base_m: [px + dx, py, pz + dz],
                offset_m: [dx, dz],
                standard_error_m: [
                    (sigma2 * inverse[(0, 0)]).sqrt(),
                    (sigma2 * inverse[(1, 1)]).sqrt(),
                ],
                plate_height_m: plate,
                rms_residual_m: (rss / n as f64).sqrt(),
                max_residual_m: residuals.iter().fold(0.0, |m, r| m.max(r.abs())),
                touches: n,
            });
        }
        dx += delta.x;
        dz += delta.y;
        plate += delta.z;
        h = heights(model, &q, dx, dz).map_err(kin)?;
    }
    Err(LevelPivotError::NoConvergence {
        iterations: ITERATIONS,
    })
}

#[cfg(test)]
#[path = "level_pivot_tests.rs"]
mod tests;
