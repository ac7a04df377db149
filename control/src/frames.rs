//! Points and frames.
//!
//! Two frames matter. The *robot base frame* is the Phantom's own: origin at the gimbal point
//! in the home pose, `y` up, `z` toward the operator. The *tissue frame* has its origin on the
//! tissue surface, `x` along the expected artery course, `y` up (out of the tissue) and `z`
//! lateral; the tactile element line lies along tissue `z` and keeps that direction because
//! the instrument cannot roll. Both are right-handed and share the vertical axis, so the map
//! between them is a yaw about `y` plus a translation.

use nalgebra::{Point3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// The wrist gimbal point G, robot base frame, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gimbal(pub Point3<f64>);

/// The fixed pivot P (the incision), robot base frame, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pivot(pub Point3<f64>);

/// The rod's lower end T, where the sensor is pinned, robot base frame, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tip(pub Point3<f64>);

/// A point on the tissue surface in the tissue frame (`y` = 0), m.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct SurfacePoint {
    pub x_m: f64,
    pub z_m: f64,
}

impl SurfacePoint {
    pub const fn new(x_m: f64, z_m: f64) -> Self {
        Self { x_m, z_m }
    }

    pub fn distance_to(&self, other: &SurfacePoint) -> f64 {
        (self.x_m - other.x_m).hypot(self.z_m - other.z_m)
    }

    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.z_m.is_finite()
    }
}

/// Where the tissue frame sits in the robot base frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TissuePlacement {
    /// The tissue frame's origin expressed in the robot base frame, m.
    pub origin_in_base_m: [f64; 3],
    /// Rotation about the common vertical axis taking tissue axes to base axes, rad.
    pub yaw_rad: f64,
}

impl TissuePlacement {
    fn rotation(&self) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Vector3::y_axis(), self.yaw_rad)
    }

    fn origin(&self) -> Point3<f64> {
        Point3::from(self.origin_in_base_m)
    }

    /// A tissue-frame point expressed in the robot base frame.
    pub fn to_base(&self, p_tissue: &Point3<f64>) -> Point3<f64> {
        self.origin() + self.rotation() * p_tissue.coords
    }

    /// A robot-base-frame point expressed in the tissue frame.
    pub fn to_tissue(&self, p_base: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation().inverse() * (p_base - self.origin()))
    }

    /// A tissue-frame direction expressed in the robot base frame.
    pub fn direction_to_base(&self, v_tissue: &Vector3<f64>) -> Vector3<f64> {
        self.rotation() * v_tissue
    }

    /// A robot-base-frame direction expressed in the tissue frame.
    pub fn direction_to_tissue(&self, v_base: &Vector3<f64>) -> Vector3<f64> {
        self.rotation().inverse() * v_base
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placement_round_trips_and_rotates_about_vertical() {
        let placement = TissuePlacement {
            origin_in_base_m: [0.01, -0.3, 0.05],
            yaw_rad: 0.7,
        };
        let p = Point3::new(0.12, 0.0, -0.04);
        let back = placement.to_tissue(&placement.to_base(&p));
        assert!((back - p).norm() < 1e-15);
        // Height is untouched by a yaw.
        assert!((placement.to_base(&p).y - (-0.3)).abs() < 1e-15);
        // A quarter turn takes tissue x to base -z (right-handed rotation about +y).
        let quarter = TissuePlacement {
            origin_in_base_m: [0.0; 3],
            yaw_rad: std::f64::consts::FRAC_PI_2,
        };
        let v = quarter.direction_to_base(&Vector3::x());
        assert!((v - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-15);
        assert!((quarter.direction_to_tissue(&v) - Vector3::x()).norm() < 1e-15);
    }
}
