//! Arm and rod geometry, joint limits and where the tissue lies.

use control::frames::TissuePlacement;
use control::kinematics::{JointLimits, PhantomGeometry, PivotGeometry};
use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotSection {
    pub phantom: PhantomGeometry,
    pub joint_limits: JointLimits,
    pub pivot: PivotGeometry,
    /// Where the tissue frame lies in the robot base frame.
    pub tissue: TissuePlacement,
    /// From the rod tip T to the centre of the element line, tissue frame, m (the rod ends
    /// on the 9 mm sensor cylinder's axis; the elements lie along its bottom edge).
    pub sensor_offset_m: [f64; 3],
}

impl Default for RobotSection {
    fn default() -> Self {
        let pivot = PivotGeometry::default();
        let sensor_offset_m = [0.0, -0.0045, 0.0];
        // Tissue surface directly under the pivot, touched by the sensor at a depth of
        // 0.30 m below the pivot; tissue x along the Phantom's depth axis (its longest
        // workspace dimension).
        let surface_y = pivot.pivot_in_base_m[1] - 0.30 + sensor_offset_m[1];
        Self {
            phantom: PhantomGeometry::default(),
            joint_limits: JointLimits::default(),
            pivot,
            tissue: TissuePlacement {
                origin_in_base_m: [
                    pivot.pivot_in_base_m[0],
                    surface_y,
                    pivot.pivot_in_base_m[2],
                ],
                yaw_rad: std::f64::consts::FRAC_PI_2,
            },
            sensor_offset_m,
        }
    }
}

impl Validate for RobotSection {
    fn validate(&self, v: &mut Validator) {
        v.at("phantom", |v| {
            v.positive("l1_m", self.phantom.l1_m);
            v.positive("l2_m", self.phantom.l2_m);
        });
        v.at("joint_limits", |v| {
            let l = &self.joint_limits;
            v.all_finite("min_rad", &l.min_rad);
            v.all_finite("max_rad", &l.max_rad);
            for i in 0..l.min_rad.len() {
                v.check(
                    l.min_rad[i] < l.max_rad[i],
                    &format!("max_rad[{i}]"),
                    format!("must exceed min_rad[{i}] = {}", l.min_rad[i]),
                );
            }
            v.finite("coupling_min_rad", l.coupling_min_rad);
            v.finite("coupling_max_rad", l.coupling_max_rad);
            v.check(
                l.coupling_min_rad < l.coupling_max_rad,
                "coupling_max_rad",
                "must exceed coupling_min_rad",
            );
        });
        v.at("pivot", |v| {
            let p = &self.pivot;
            v.positive("rod_length_m", p.rod_length_m);
            v.all_finite("pivot_in_base_m", &p.pivot_in_base_m);
            v.positive("min_depth_m", p.min_depth_m);
            v.positive("max_depth_m", p.max_depth_m);
            v.check(
                p.min_depth_m < p.max_depth_m,
                "max_depth_m",
                "must exceed min_depth_m",
            );
            v.check(
                p.max_depth_m < p.rod_length_m,
                "max_depth_m",
                format!("must be less than the rod length {} m", p.rod_length_m),
            );
        });
        v.at("tissue", |v| {
            v.all_finite("origin_in_base_m", &self.tissue.origin_in_base_m);
            v.finite("yaw_rad", self.tissue.yaw_rad);
        });
        v.all_finite("sensor_offset_m", &self.sensor_offset_m);
    }
}
