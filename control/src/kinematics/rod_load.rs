//! Where a compliant rod truly puts the sensor, from the force the arm holds it with.
//!
//! The rigid map ([`super::ArmModel::sensor_from_joints`]) puts the sensor where a straight
//! rod through a fixed pivot would. A real rod bends and the incision gives, so the sensor
//! sits `c · F⊥` aside (overhanging-beam tip deflection plus the pivot's spring through the
//! lever, the simulator's model and the usual one for a shaft through a trocar):
//!
//! ```text
//! c = d² L / (3 E I)  +  (L / a)² / k_pivot          a = |P − G|, d = L − a
//! ```
//!
//! with `F⊥` the load at the tip across the rod: the tissue's push and friction and the
//! weight carried near the tip. The tissue's part is not known in advance (friction holds
//! the tip wherever the rod came to rest), but the arm feels it: at rest the joint torques
//! beyond the arm's own gravity balance the rod's push on the gimbal, and that push is the
//! tip load through the lever, `f_G = axial(F) + (1 − L/a) across(F)` (the gimbal is a ball
//! joint: force, no moment), plus the rod's and the added mass's weights at their own
//! distances. Inverting the lever gives the tip load, and `c` turns it into the deflection.
//!
//! What this cannot see: the joints' own Coulomb friction (a few mN·m on a Phantom, read as
//! a tip load of tens of mN), the arm's inertia during fast moves, a friction element in
//! the incision that holds the pivot without its spring giving, and a rod whose compliance
//! is not the configured one. It is a model of the rig, checked against the simulator's in
//! the tests.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// The instrument's mechanics as far as its bending and weight go (robot calibration).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RodMechanics {
    /// Bending stiffness E·I of the shaft, N·m².
    pub bending_stiffness_nm2: f64,
    /// Lateral stiffness of the incision (the pivot), N/m.
    pub pivot_stiffness_n_per_m: f64,
    /// The shaft's own mass, kg (its weight acts at its middle).
    #[serde(default)]
    pub rod_mass_kg: f64,
    /// Mass carried near the tip (sensor and added mass), kg, and how far above the tip it
    /// hangs, m.
    #[serde(default)]
    pub tip_mass_kg: f64,
    #[serde(default)]
    pub tip_mass_height_m: f64,
}

/// Why a load could not be turned into a deflection.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum RodLoadError {
    #[error("the rod's mechanics are not finite and positive: {what}")]
    InvalidMechanics { what: &'static str },
    #[error("the gimbal is at the lever's fulcrum (L/a = 1): the tip load cannot be read")]
    NoLever,
    #[error("a non-finite {what}")]
    NonFinite { what: &'static str },
}

/// The rod at one instant, in the robot base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodAt {
    /// Unit vector from the gimbal toward the tip.
    pub axis: Vector3<f64>,
    /// Gimbal to pivot, m.
    pub gimbal_to_pivot_m: f64,
    /// Gimbal to tip, m.
    pub length_m: f64,
}

impl RodMechanics {
    pub fn check(&self) -> Result<(), RodLoadError> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let non_negative = |v: f64| v.is_finite() && v >= 0.0;
        if !positive(self.bending_stiffness_nm2) {
            return Err(RodLoadError::InvalidMechanics {
                what: "bending_stiffness_nm2",
            });
        }
        if !positive(self.pivot_stiffness_n_per_m) {
            return Err(RodLoadError::InvalidMechanics {
                what: "pivot_stiffness_n_per_m",
            });
        }
        for (v, what) in [
            (self.rod_mass_kg, "rod_mass_kg"),
            (self.tip_mass_kg, "tip_mass_kg"),
            (self.tip_mass_height_m, "tip_mass_height_m"),
        ] {
            if !non_negative(v) {
                return Err(RodLoadError::InvalidMechanics { what });
            }
        }
        Ok(())
    }

    /// Lateral tip compliance, m/N, at gimbal-to-pivot distance `a`.
    pub fn compliance_m_per_n(&self, rod: &RodAt) -> f64 {
        let (l, a) = (rod.length_m, rod.gimbal_to_pivot_m.max(1e-3));
        let d = (l - a).max(0.0);
        d * d * l / (3.0 * self.bending_stiffness_nm2)
            + (l / a).powi(2) / self.pivot_stiffness_n_per_m
    }

    /// The weights on the rod as (load, distance from the gimbal along the rod), base frame.
    fn weights(&self, rod: &RodAt, gravity_m_s2: f64) -> [(Vector3<f64>, f64); 2] {
        let down = Vector3::new(0.0, -gravity_m_s2, 0.0);
        [
            (down * self.rod_mass_kg, rod.length_m / 2.0),
            (
                down * self.tip_mass_kg,
                rod.length_m - self.tip_mass_height_m,
            ),
        ]
    }

    /// The load at the tip (base frame, N) from the force the rod pushes on the gimbal:
    /// the lever inverted after the weights' own share is taken off.
    pub fn tip_load_n(
        &self,
        rod: &RodAt,
        gimbal_force_n: &Vector3<f64>,
        gravity_m_s2: f64,
    ) -> Result<Vector3<f64>, RodLoadError> {
        let u = rod.axis;
        let a = rod.gimbal_to_pivot_m;
        let lever = 1.0 - rod.length_m / a;
        if !lever.is_finite() || lever.abs() < 1e-6 {
            return Err(RodLoadError::NoLever);
        }
        let mut rest = *gimbal_force_n;
        for (w, s) in self.weights(rod, gravity_m_s2) {
            let axial = w.dot(&u) * u;
            rest -= axial + (w - axial) * (1.0 - s / a);
        }
        let axial = rest.dot(&u) * u;
        let f = axial + (rest - axial) / lever;
        if f.iter().all(|v| v.is_finite()) {
            Ok(f)
        } else {
            Err(RodLoadError::NonFinite { what: "tip load" })
        }
    }

    /// How far the tip sits from the straight rod's (base frame, m) under `tip_load_n` (the
    /// tissue's force on the tip) and the weight carried near the tip.
    pub fn tip_deflection_m(
        &self,
        rod: &RodAt,
        tip_load_n: &Vector3<f64>,
        gravity_m_s2: f64,
    ) -> Vector3<f64> {
        let u = rod.axis;
        let load = tip_load_n + Vector3::new(0.0, -gravity_m_s2 * self.tip_mass_kg, 0.0);
        let across = (Matrix3::identity() - u * u.transpose()) * load;
        across * self.compliance_m_per_n(rod)
    }
}

#[cfg(test)]
#[path = "rod_load_tests.rs"]
mod tests;
