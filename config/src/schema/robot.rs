//! Arm and rod geometry, joint limits and where the tissue lies.

use control::frames::TissuePlacement;
use control::kinematics::{
    ArmModel, DEFAULT_SENSOR_OFFSET_M, DEFAULT_SURFACE_DEPTH_M, JointLimits, KinematicsError,
    PhantomGeometry, PivotGeometry, tissue_under_pivot,
};
use control::pd::PhantomMasses;
use nalgebra::Point3;
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
    /// The arm's own bodies, for gravity compensation (never the rod, sensor or the mass on
    /// the shaft: their weight is the contact force).
    pub link_masses: PhantomMasses,
}

impl Default for RobotSection {
    fn default() -> Self {
        // Tissue surface straight under the pivot, touched by the sensor centre with the rod
        // vertical and its tip 0.28 m deep; tissue x along the base x axis, the Phantom's
        // widest (base-yaw) direction. docs/kinematics.md shows the sweep of the seed's
        // patch that this placement passes.
        let pivot = PivotGeometry::default();
        Self {
            phantom: PhantomGeometry::default(),
            joint_limits: JointLimits::default(),
            pivot,
            tissue: tissue_under_pivot(
                &pivot,
                DEFAULT_SENSOR_OFFSET_M,
                DEFAULT_SURFACE_DEPTH_M,
                0.0,
            ),
            sensor_offset_m: DEFAULT_SENSOR_OFFSET_M,
            link_masses: PhantomMasses::default(),
        }
    }
}

impl RobotSection {
    /// The composed kinematic model this section describes.
    pub fn arm_model(&self) -> Result<ArmModel, KinematicsError> {
        ArmModel::new(
            self.phantom,
            self.joint_limits,
            self.pivot,
            self.tissue,
            self.sensor_offset_m,
        )
    }
}

impl Validate for RobotSection {
    fn validate(&self, v: &mut Validator) {
        let problems_before = v.problem_count();
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
            let half_pi = std::f64::consts::FRAC_PI_2;
            v.check(
                l.coupling_min_rad >= -half_pi,
                "coupling_min_rad",
                "must be at least −π/2 (the links folded flat)",
            );
            v.check(
                l.coupling_max_rad <= half_pi,
                "coupling_max_rad",
                "must be at most π/2 (the arm stretched straight)",
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
        v.at("link_masses", |v| {
            let m = &self.link_masses;
            v.in_range("gravity_m_s2", m.gravity_m_s2, 0.0, 20.0);
            for (name, body) in [
                ("forearm", m.forearm),
                ("parallel_link", m.parallel_link),
                ("upper_arm", m.upper_arm),
                ("drive_link", m.drive_link),
                ("gimbal", m.gimbal),
            ] {
                v.at(name, |v| {
                    v.in_range("mass_kg", body.mass_kg, 0.0, 5.0);
                    v.in_range("along_upper_arm_m", body.along_upper_arm_m, -1.0, 1.0);
                    v.in_range("along_forearm_m", body.along_forearm_m, -1.0, 1.0);
                });
            }
        });
        // The pieces together: a model must build, and the sensor must reach the tissue
        // origin on the surface, or nothing else can work. Only once each field is sane.
        if v.problem_count() > problems_before {
            return;
        }
        match self.arm_model() {
            Err(e) => v.problem("", format!("the arm model cannot be built: {e}")),
            Ok(arm) => {
                if let Err(e) = arm.joints_for_sensor(&Point3::origin()) {
                    v.problem(
                        "tissue",
                        format!("the sensor cannot reach the tissue origin: {e}"),
                    );
                }
            }
        }
    }
}

#[cfg(test)]
#[path = "robot_tests.rs"]
mod tests;
