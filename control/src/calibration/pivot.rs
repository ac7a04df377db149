//! The pivot (incision) as the point closest, in least squares, to a set of rod lines.
//!
//! With the rod through the incision the arm visits several poses; at each the rod is a line
//! (a point on it and its direction, base frame). The pivot p minimises Σ |(I − uᵢuᵢᵀ)(p − aᵢ)|²,
//! the squared distances to the lines, which is the 3 × 3 normal system
//!
//! ```text
//! A p = b,   A = Σ (I − uᵢuᵢᵀ),   b = Σ (I − uᵢuᵢᵀ) aᵢ
//! ```
//!
//! Hand-written (a 3 × 3 symmetric eigenproblem with nalgebra) because its conditioning is the
//! result's main diagnostic: the smallest eigenvalue of A is n(1 − max_w mean (uᵢ·w)²), so
//! `spread = asin √(λmin/n)` is the angle whose sine is the RMS sine of the rods' angles from
//! their best common axis (for a narrow cone, their RMS angle; for two rods, half the angle
//! between them), and the pivot's standard error along that axis is
//! σ/√λmin with σ² = Σ dᵢ²/(2n − 3). Parallel rods leave the pivot free to slide along them.

use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};
use thiserror::Error;

use super::tolerance::{Check, Tolerances};
use crate::frames::{Gimbal, Pivot, Tip};
use crate::kinematics::PivotGeometry;

/// Rods whose spread about their common axis is below this are refused as parallel: the
/// normal matrix's smallest eigenvalue is then n·spread² < 1e-12·n, where the solve keeps
/// only a few of its digits (rounding in b, about 1e-16 of the coordinates, is divided by it).
pub const PARALLEL_SPREAD_RAD: f64 = 1e-6;

/// One rod pose: a line through `point` along `direction` (need not be unit), base frame, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodLine {
    pub point: Point3<f64>,
    pub direction: Vector3<f64>,
}

impl RodLine {
    pub fn new(point: Point3<f64>, direction: Vector3<f64>) -> Self {
        Self { point, direction }
    }

    /// The rod through the gimbal point along a measured direction (e.g. from the gimbal's
    /// encoders).
    pub fn from_gimbal(gimbal: &Gimbal, direction: Vector3<f64>) -> Self {
        Self::new(gimbal.0, direction)
    }

    /// The rod through the gimbal point and the rod tip (when the tip's position is measured,
    /// e.g. touching a point known in the base frame).
    pub fn through(gimbal: &Gimbal, tip: &Tip) -> Self {
        Self::new(gimbal.0, tip.0 - gimbal.0)
    }
}

/// Why no pivot was fitted.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum PivotFitError {
    #[error("need at least 2 rod lines to fix a pivot, got {lines}")]
    TooFewLines { lines: usize },

    #[error("rod line {line}: its {what} is not finite")]
    NonFinite { line: usize, what: &'static str },

    #[error("rod line {line}: its direction is the zero vector")]
    ZeroDirection { line: usize },

    #[error("the fit overflowed: the rod lines' coordinates are too large for it")]
    Overflow,

    #[error(
        "the rod lines are parallel: their directions spread {spread_rad:.3e} rad about a \
         common axis (below {min_rad:.1e} rad), so the pivot could lie anywhere along them; \
         move the arm through a cone of poses"
    )]
    Parallel { spread_rad: f64, min_rad: f64 },
}

/// The fitted pivot and how well the lines fix it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PivotFit {
    pub pivot: Pivot,
    /// RMS distance of the pivot from the lines, m.
    pub rms_residual_m: f64,
    /// Largest distance of the pivot from a line, m, and that line's index.
    pub max_residual_m: f64,
    pub worst_line: usize,
    /// Spread of the rods about their best common axis, rad: `asin √(λmin/n)`, the angle whose
    /// sine is the RMS sine of their angles from it.
    pub spread_rad: f64,
    /// Smallest eigenvalue λmin of the normal matrix A (between 0 and n).
    pub min_eigenvalue: f64,
    /// λmax/λmin of the normal matrix.
    pub condition_number: f64,
    /// Standard error of the pivot along its worst-fixed direction, m (σ/√λmin, σ estimated
    /// from the residuals; 0 for two lines that meet).
    pub standard_error_m: f64,
    pub lines: usize,
}

impl PivotFit {
    /// The configured pivot geometry with this pivot in place of the configured one.
    pub fn apply_to(&self, geometry: &PivotGeometry) -> PivotGeometry {
        PivotGeometry {
            pivot_in_base_m: [self.pivot.0.x, self.pivot.0.y, self.pivot.0.z],
            ..*geometry
        }
    }

    /// The residual and the conditioning against their tolerances.
    pub fn checks(&self, tolerances: &Tolerances) -> [Check; 2] {
        [
            Check::at_most(
                "pivot RMS residual",
                self.rms_residual_m,
                tolerances.pivot_max_rms_residual_m,
                "m",
            ),
            Check::at_least(
                "spread of the rod directions",
                self.spread_rad,
                tolerances.pivot_min_spread_rad,
                "rad",
            ),
        ]
    }
}

/// The least-squares pivot of `lines` (base frame).
pub fn fit_pivot(lines: &[RodLine]) -> Result<PivotFit, PivotFitError> {
    if lines.len() < 2 {
        return Err(PivotFitError::TooFewLines { lines: lines.len() });
    }
    let mut units = Vec::with_capacity(lines.len());
    for (line, l) in lines.iter().enumerate() {
        if !l.point.iter().all(|v| v.is_finite()) {
            return Err(PivotFitError::NonFinite {
                line,
                what: "point",
            });
        }
        if !l.direction.iter().all(|v| v.is_finite()) {
            return Err(PivotFitError::NonFinite {
                line,
                what: "direction",
            });
        }
        // Rescaled first so that tiny but valid directions (in any unit) are kept.
        let scale = l.direction.amax();
        if scale <= 0.0 {
            return Err(PivotFitError::ZeroDirection { line });
        }
        units.push((l.direction / scale).normalize());
    }
    let n = lines.len() as f64;
    // Centred on the mean of the given points, so that b carries no large common offset.
    let centre = lines
        .iter()
        .fold(Vector3::zeros(), |acc, l| acc + l.point.coords)
        / n;
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for (l, u) in lines.iter().zip(&units) {
        let across = Matrix3::identity() - u * u.transpose();
        a += across;
        b += across * (l.point.coords - centre);
    }
    let eigen = SymmetricEigen::new(a);
    let lambda_min = eigen.eigenvalues.min();
    let lambda_max = eigen.eigenvalues.max();
    let spread_rad = (lambda_min / n).clamp(0.0, 1.0).sqrt().asin();
    if spread_rad.is_nan() || spread_rad < PARALLEL_SPREAD_RAD {
        return Err(PivotFitError::Parallel {
            spread_rad,
            min_rad: PARALLEL_SPREAD_RAD,
        });
    }
    let v = &eigen.eigenvectors;
    let inverse_eigen = Matrix3::from_diagonal(&eigen.eigenvalues.map(|l| 1.0 / l));
    let p = Point3::from(centre + v * inverse_eigen * v.transpose() * b);

    let (mut sum_sq, mut max_residual_m, mut worst_line) = (0.0, 0.0, 0);
    for (i, (l, u)) in lines.iter().zip(&units).enumerate() {
        let w = p - l.point;
        let d = (w - u * u.dot(&w)).norm();
        sum_sq += d * d;
        if d > max_residual_m {
            max_residual_m = d;
            worst_line = i;
        }
    }
    // Each line constrains the two directions across it; the pivot uses three.
    let sigma = (sum_sq / (2.0 * n - 3.0)).sqrt();
    if !(p.iter().all(|v| v.is_finite()) && sum_sq.is_finite()) {
        return Err(PivotFitError::Overflow);
    }
    Ok(PivotFit {
        pivot: Pivot(p),
        rms_residual_m: (sum_sq / n).sqrt(),
        max_residual_m,
        worst_line,
        spread_rad,
        min_eigenvalue: lambda_min,
        condition_number: lambda_max / lambda_min,
        standard_error_m: sigma / lambda_min.sqrt(),
        lines: lines.len(),
    })
}

#[cfg(test)]
#[path = "pivot_tests.rs"]
mod tests;
