//! The region of the tissue surface a search may explore: an axis-aligned rectangle in the
//! tissue frame that the sensor centre never leaves.

use serde::{Deserialize, Serialize};

use crate::frames::SurfacePoint;

/// Smallest side a region may have, m: less than the array's own span leaves nothing to
/// search.
pub const MIN_SIDE_M: f64 = 0.005;
/// Largest side, m: a region larger than a hand is a request for a survey, not a search.
pub const MAX_SIDE_M: f64 = 0.2;

/// A rectangle on the tissue surface, tissue frame, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    pub x0_m: f64,
    pub z0_m: f64,
    pub x1_m: f64,
    pub z1_m: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RegionError {
    #[error("region corner {what} is not a finite number")]
    NonFinite { what: &'static str },
    #[error("region side along {axis} is {side_m} m; it must be {MIN_SIDE_M} to {MAX_SIDE_M} m")]
    BadSide { axis: &'static str, side_m: f64 },
}

impl Region {
    /// The region with corners in any order, checked.
    pub fn new(a: SurfacePoint, b: SurfacePoint) -> Result<Self, RegionError> {
        for (what, v) in [("x0", a.x_m), ("z0", a.z_m), ("x1", b.x_m), ("z1", b.z_m)] {
            if !v.is_finite() {
                return Err(RegionError::NonFinite { what });
            }
        }
        let r = Self {
            x0_m: a.x_m.min(b.x_m),
            z0_m: a.z_m.min(b.z_m),
            x1_m: a.x_m.max(b.x_m),
            z1_m: a.z_m.max(b.z_m),
        };
        r.validate()?;
        Ok(r)
    }

    /// A square of side `side_m` centred on `centre`.
    pub fn square(centre: SurfacePoint, side_m: f64) -> Result<Self, RegionError> {
        let h = side_m / 2.0;
        Self::new(
            SurfacePoint::new(centre.x_m - h, centre.z_m - h),
            SurfacePoint::new(centre.x_m + h, centre.z_m + h),
        )
    }

    /// Check a region as read from outside (a file or the console).
    pub fn validate(&self) -> Result<(), RegionError> {
        for (what, v) in [
            ("x0", self.x0_m),
            ("z0", self.z0_m),
            ("x1", self.x1_m),
            ("z1", self.z1_m),
        ] {
            if !v.is_finite() {
                return Err(RegionError::NonFinite { what });
            }
        }
        for (axis, side_m) in [("x", self.width_m()), ("z", self.height_m())] {
            if !(MIN_SIDE_M..=MAX_SIDE_M).contains(&side_m) {
                return Err(RegionError::BadSide { axis, side_m });
            }
        }
        Ok(())
    }

    pub fn width_m(&self) -> f64 {
        self.x1_m - self.x0_m
    }

    pub fn height_m(&self) -> f64 {
        self.z1_m - self.z0_m
    }

    pub fn centre(&self) -> SurfacePoint {
        SurfacePoint::new(0.5 * (self.x0_m + self.x1_m), 0.5 * (self.z0_m + self.z1_m))
    }

    /// Is `p` inside (edges included)?
    pub fn contains(&self, p: SurfacePoint) -> bool {
        (self.x0_m..=self.x1_m).contains(&p.x_m) && (self.z0_m..=self.z1_m).contains(&p.z_m)
    }

    /// The region shrunk by `margin_m` on every side (to its middle line where it is
    /// narrower than twice the margin). Not validated: it may be a line or a point.
    pub fn inset(&self, margin_m: f64) -> Region {
        let mx = margin_m.min(self.width_m() / 2.0);
        let mz = margin_m.min(self.height_m() / 2.0);
        Region {
            x0_m: self.x0_m + mx,
            z0_m: self.z0_m + mz,
            x1_m: self.x1_m - mx,
            z1_m: self.z1_m - mz,
        }
    }

    /// The nearest point of the region to `p`.
    pub fn clamp(&self, p: SurfacePoint) -> SurfacePoint {
        SurfacePoint::new(
            p.x_m.clamp(self.x0_m, self.x1_m),
            p.z_m.clamp(self.z0_m, self.z1_m),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_in_any_order_and_bad_input_named() {
        let r = Region::new(
            SurfacePoint::new(0.02, 0.01),
            SurfacePoint::new(-0.02, -0.03),
        )
        .expect("region");
        assert_eq!((r.x0_m, r.z0_m, r.x1_m, r.z1_m), (-0.02, -0.03, 0.02, 0.01));
        assert!(r.contains(r.centre()));
        assert!(!r.contains(SurfacePoint::new(0.021, 0.0)));
        assert_eq!(
            r.clamp(SurfacePoint::new(1.0, -1.0)),
            SurfacePoint::new(0.02, -0.03)
        );
        let e = Region::new(
            SurfacePoint::new(f64::NAN, 0.0),
            SurfacePoint::new(0.02, 0.02),
        )
        .expect_err("NaN");
        assert!(e.to_string().contains("x0"), "{e}");
        let e = Region::square(SurfacePoint::new(0.0, 0.0), 0.001).expect_err("tiny");
        assert!(e.to_string().contains("along x"), "{e}");
        assert!(Region::square(SurfacePoint::new(0.0, 0.0), 1.0).is_err());
    }
}
