//! A straight line through recent artery points, with no preferred axis.
//!
//! The seed extrapolates by "linear regression" over the last (up to) four located
//! points. Regressing `z` on `x` would fail for a path running along `z` and weigh the two
//! axes unequally, so the line here is the orthogonal (total-least-squares) fit: through
//! the centroid, along the principal axis of the points' scatter. It is oriented along the
//! direction of travel, found by regressing each point's position along the line on its
//! order (oldest first). Degenerate inputs are handled explicitly:
//! - fewer than two points, or all points coincident: no line;
//! - two points, or collinear points: the exact line through them;
//! - an isotropic scatter (no principal axis, e.g. the corners of a square): the chord from
//!   the oldest to the newest point.

use crate::frames::SurfacePoint;

/// A directed line in the tissue surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathLine {
    /// A point on the line (the centroid of the fitted points).
    pub origin: SurfacePoint,
    /// Unit direction of travel, (x, z).
    pub direction: [f64; 2],
}

/// Scatter below this RMS distance, m, counts as one point (far below any real resolution).
const COINCIDENT_M: f64 = 1e-9;

impl PathLine {
    /// Fit to points ordered oldest first.
    pub fn fit(points: &[SurfacePoint]) -> Option<Self> {
        let n = points.len();
        if n < 2 || !points.iter().all(SurfacePoint::is_finite) {
            return None;
        }
        let nf = n as f64;
        let cx = points.iter().map(|p| p.x_m).sum::<f64>() / nf;
        let cz = points.iter().map(|p| p.z_m).sum::<f64>() / nf;
        let (mut sxx, mut szz, mut sxz) = (0.0, 0.0, 0.0);
        for p in points {
            let (dx, dz) = (p.x_m - cx, p.z_m - cz);
            sxx += dx * dx;
            szz += dz * dz;
            sxz += dx * dz;
        }
        let spread = sxx + szz;
        if spread <= nf * COINCIDENT_M * COINCIDENT_M {
            return None;
        }
        // Difference of the scatter matrix's eigenvalues; zero for an isotropic scatter.
        let anisotropy = (sxx - szz).hypot(2.0 * sxz);
        let oldest = points[0];
        let newest = points[n - 1];
        let mut direction = if anisotropy > 1e-9 * spread {
            let angle = 0.5 * (2.0 * sxz).atan2(sxx - szz);
            [angle.cos(), angle.sin()]
        } else {
            let chord = [newest.x_m - oldest.x_m, newest.z_m - oldest.z_m];
            let length = chord[0].hypot(chord[1]);
            if length <= COINCIDENT_M {
                return None;
            }
            [chord[0] / length, chord[1] / length]
        };
        // Orient along travel: the slope of position-along-the-line against point order.
        let mean_k = (nf - 1.0) / 2.0;
        let trend: f64 = points
            .iter()
            .enumerate()
            .map(|(k, p)| {
                (k as f64 - mean_k) * ((p.x_m - cx) * direction[0] + (p.z_m - cz) * direction[1])
            })
            .sum();
        let chord_along =
            (newest.x_m - oldest.x_m) * direction[0] + (newest.z_m - oldest.z_m) * direction[1];
        if trend < 0.0 || (trend == 0.0 && chord_along < 0.0) {
            direction = [-direction[0], -direction[1]];
        }
        Some(Self {
            origin: SurfacePoint::new(cx, cz),
            direction,
        })
    }

    /// Signed position of `p`'s foot along the line from the origin, m.
    pub fn along(&self, p: &SurfacePoint) -> f64 {
        (p.x_m - self.origin.x_m) * self.direction[0]
            + (p.z_m - self.origin.z_m) * self.direction[1]
    }

    /// Signed distance of `p` from the line (positive to the left of travel), m.
    pub fn across(&self, p: &SurfacePoint) -> f64 {
        (p.z_m - self.origin.z_m) * self.direction[0]
            - (p.x_m - self.origin.x_m) * self.direction[1]
    }

    /// The point at signed position `s` along the line, m.
    pub fn at(&self, s: f64) -> SurfacePoint {
        SurfacePoint::new(
            self.origin.x_m + s * self.direction[0],
            self.origin.z_m + s * self.direction[1],
        )
    }

    /// The point `step_m` beyond the foot of `p` in the direction of travel.
    pub fn beyond(&self, p: &SurfacePoint, step_m: f64) -> SurfacePoint {
        self.at(self.along(p) + step_m)
    }
}
