//! Gravity compensation: the joint torques that hold the arm's own weight.
//!
//! On the Phantom's parallel drive every body's height depends on θ2 and θ3 separately, so a
//! body is described by its mass and by where its centre of mass sits as a distance along
//! the upper arm (direction θ2) plus a distance along the forearm (direction θ3, downward
//! when θ3 = 0): height = a sin θ2 − f cos θ3 + const. Holding it takes
//! `τ2 = g m a cos θ2` and `τ3 = g m f sin θ3`; θ1 turns about the vertical and needs none.
//!
//! What is *not* compensated, deliberately: the rod, the sensor and the seed's 0.3 kg mass on
//! the shaft. Their weight is what presses the sensor into the tissue (the seed found 0.2 kg
//! too little to feel the pulse over the noise), so the low-gain PD lets it rest there.

use serde::{Deserialize, Serialize};

use crate::types::Joints;

/// Something that knows the joint torques needed to hold the arm still against gravity.
pub trait GravityModel {
    /// N·m at each joint (after the capstan) for joint angles `q`. Must not allocate.
    fn torque_nm(&self, q: &Joints) -> Joints;
}

/// No compensation (a plant without gravity, or a rig that is counterbalanced well enough).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoGravity;

impl GravityModel for NoGravity {
    fn torque_nm(&self, _q: &Joints) -> Joints {
        [0.0; 3]
    }
}

/// One body of the arm as gravity sees it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PointMass {
    pub mass_kg: f64,
    /// Centre of mass along the upper arm from the shoulder axis, m (negative: behind it).
    pub along_upper_arm_m: f64,
    /// Centre of mass along the forearm direction, m (negative: opposite the forearm).
    pub along_forearm_m: f64,
}

/// The Phantom's moving bodies. Defaults: Cavusoglu, Feygin & Tendick (2002), the identified
/// Phantom 1.5 model (l3 = 0.0325, l5 = −0.0368, l6 = 0.0527 m); the wrist gimbal is a rig
/// measurement (0 by default: the seed removed its last joint and the rest is light).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhantomMasses {
    pub gravity_m_s2: f64,
    /// The forearm (their link a): hangs from the elbow, centre halfway down.
    pub forearm: PointMass,
    /// The parallel link (c) that carries θ3's drive to the elbow.
    pub parallel_link: PointMass,
    /// The upper arm with its motor counterweight behind the shoulder (be).
    pub upper_arm: PointMass,
    /// The θ3 drive link and its counterweight (df), turning with θ3 opposite the forearm.
    pub drive_link: PointMass,
    /// The wrist gimbal at the gimbal point (along_upper_arm = l1, along_forearm = l2).
    pub gimbal: PointMass,
}

impl Default for PhantomMasses {
    fn default() -> Self {
        Self {
            gravity_m_s2: 9.81,
            forearm: PointMass {
                mass_kg: 0.0202,
                along_upper_arm_m: 0.215,
                along_forearm_m: 0.085,
            },
            parallel_link: PointMass {
                mass_kg: 0.0249,
                along_upper_arm_m: 0.1075,
                along_forearm_m: 0.0325,
            },
            upper_arm: PointMass {
                mass_kg: 0.2359,
                along_upper_arm_m: -0.0368,
                along_forearm_m: 0.0,
            },
            drive_link: PointMass {
                mass_kg: 0.1906,
                along_upper_arm_m: 0.0,
                along_forearm_m: -0.0527,
            },
            gimbal: PointMass {
                mass_kg: 0.0,
                along_upper_arm_m: 0.215,
                along_forearm_m: 0.170,
            },
        }
    }
}

impl PhantomMasses {
    pub fn bodies(&self) -> [PointMass; 5] {
        [
            self.forearm,
            self.parallel_link,
            self.upper_arm,
            self.drive_link,
            self.gimbal,
        ]
    }
}

/// Gravity torques of the Phantom's own bodies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhantomGravity {
    /// g · Σ m a: the θ2 moment, N·m at cos θ2 = 1.
    moment_upper_nm: f64,
    /// g · Σ m f: the θ3 moment, N·m at sin θ3 = 1.
    moment_fore_nm: f64,
}

impl PhantomGravity {
    pub fn new(masses: &PhantomMasses) -> Self {
        let g = masses.gravity_m_s2;
        let bodies = masses.bodies();
        Self {
            moment_upper_nm: g * bodies
                .iter()
                .map(|b| b.mass_kg * b.along_upper_arm_m)
                .sum::<f64>(),
            moment_fore_nm: g * bodies
                .iter()
                .map(|b| b.mass_kg * b.along_forearm_m)
                .sum::<f64>(),
        }
    }
}

impl GravityModel for PhantomGravity {
    fn torque_nm(&self, q: &Joints) -> Joints {
        [
            0.0,
            self.moment_upper_nm * q[1].cos(),
            self.moment_fore_nm * q[2].sin(),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Potential energy of the bodies, for checking the torques as its gradient.
    fn potential_j(m: &PhantomMasses, q: &Joints) -> f64 {
        m.bodies()
            .iter()
            .map(|b| {
                m.gravity_m_s2
                    * b.mass_kg
                    * (b.along_upper_arm_m * q[1].sin() - b.along_forearm_m * q[2].cos())
            })
            .sum()
    }

    #[test]
    fn torques_are_the_gradient_of_the_potential() {
        let m = PhantomMasses {
            gimbal: PointMass {
                mass_kg: 0.05,
                ..PhantomMasses::default().gimbal
            },
            ..PhantomMasses::default()
        };
        let model = PhantomGravity::new(&m);
        for q in [[0.2, 0.5, 0.5], [-0.7, -0.3, 1.2], [0.0, 1.1, -0.4]] {
            let tau = model.torque_nm(&q);
            let h = 1e-6;
            for j in 0..3 {
                let (mut qp, mut qm) = (q, q);
                qp[j] += h;
                qm[j] -= h;
                let fd = (potential_j(&m, &qp) - potential_j(&m, &qm)) / (2.0 * h);
                assert!((fd - tau[j]).abs() < 1e-9, "joint {j}: {fd} vs {}", tau[j]);
            }
        }
    }

    #[test]
    fn cavusoglu_moments_by_hand() {
        // Their G2 = g (l1 ma + l5 mbe + l1 mc / 2) cos θ2 and
        // G3 = g (l2 ma / 2 + l3 mc − l6 mdf) sin θ3.
        let g = 9.81;
        let g2 = g * (0.215 * 0.0202 - 0.0368 * 0.2359 + 0.215 * 0.0249 / 2.0);
        let g3 = g * (0.170 * 0.0202 / 2.0 + 0.0325 * 0.0249 - 0.0527 * 0.1906);
        let tau = PhantomGravity::new(&PhantomMasses::default()).torque_nm(&[0.3, 0.0, 1.0]);
        assert_eq!(tau[0], 0.0);
        assert!((tau[1] - g2).abs() < 1e-15);
        assert!((tau[2] - g3 * 1.0f64.sin()).abs() < 1e-15);
        // The arm is counterbalanced: both moments are small next to the 0.32 N·m limit.
        assert!(g2.abs() < 0.03 && g3.abs() < 0.1);
        assert!(NoGravity.torque_nm(&[1.0, 1.0, 1.0]) == [0.0; 3]);
    }
}
