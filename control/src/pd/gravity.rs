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
//! too little to feel the pulse over the noise), so the low-gain PD lets it rest there. A
//! heavier instrument ([`Instrument`]) is held up by its excess over the contact load it is
//! meant to give ([`ArmGravity`]): the excess weight hangs at the rod's tip, and the rod
//! brings it to the gimbal through the pivot (`F_G = (∂T/∂G)ᵀ F_T`: the axial part whole,
//! the part across the rod times `1 − L/a`, reversed by the pivot's lever), and the gimbal
//! Jacobian to the joints: `τ = W Jᵀ (∂T/∂G)ᵀ ŷ`, the gradient of the tip's height times
//! the excess weight. Pushing straight up at the gimbal instead would leave the weight's
//! part across a leaning rod in place and add a lateral push at the tip through the lever.

use serde::{Deserialize, Serialize};

use nalgebra::Vector3;

use crate::kinematics::{PhantomGeometry, PivotGeometry, phantom, pivot};
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

/// The instrument hung on the gimbal (rod, sensor and any added mass), as the daemon's
/// config gives it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Instrument {
    /// Everything the gimbal carries below it, kg.
    pub mass_kg: f64,
    /// The part of its weight that should press the sensor into the tissue, N (the seed:
    /// its 0.3 kg mass, 2.94 N).
    pub contact_load_n: f64,
}

impl Instrument {
    /// The weight the drive holds up, N: the instrument's weight less the contact load. Never
    /// negative (a lighter instrument is left to its weight: the drive does not press it in)
    /// and 0 for non-finite input.
    pub fn excess_weight_n(&self, gravity_m_s2: f64) -> f64 {
        let w = self.mass_kg * gravity_m_s2 - self.contact_load_n;
        if w.is_finite() { w.max(0.0) } else { 0.0 }
    }
}

/// Gravity torques of the Phantom's own bodies (and of an instrument's excess weight).
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

/// The arm's own bodies and, if configured, the instrument's excess weight (see the module
/// notes): what the servo loops compensate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmGravity {
    bodies: PhantomGravity,
    instrument: Option<InstrumentLoad>,
}

/// The excess weight on the rod and the geometry that brings it to the joints.
#[derive(Debug, Clone, Copy, PartialEq)]
struct InstrumentLoad {
    excess_n: f64,
    phantom: PhantomGeometry,
    pivot: PivotGeometry,
}

impl ArmGravity {
    /// The same weights brought to the joints through `pivot` (a calibrated incision).
    pub fn with_pivot(&self, pivot: &PivotGeometry) -> Self {
        Self {
            bodies: self.bodies,
            instrument: self
                .instrument
                .map(|i| InstrumentLoad { pivot: *pivot, ..i }),
        }
    }

    /// `instrument: None` (or one no heavier than its contact load): the arm's bodies only,
    /// as [`PhantomGravity`].
    pub fn new(
        masses: &PhantomMasses,
        phantom: &PhantomGeometry,
        pivot: &PivotGeometry,
        instrument: Option<&Instrument>,
    ) -> Self {
        let instrument = instrument
            .map(|i| i.excess_weight_n(masses.gravity_m_s2))
            .filter(|&w| w > 0.0)
            .map(|excess_n| InstrumentLoad {
                excess_n,
                phantom: *phantom,
                pivot: *pivot,
            });
        Self {
            bodies: PhantomGravity::new(masses),
            instrument,
        }
    }

    /// The excess weight held up, N (0 without an instrument to compensate).
    pub fn instrument_excess_n(&self) -> f64 {
        self.instrument.map_or(0.0, |i| i.excess_n)
    }
}

impl InstrumentLoad {
    /// `W Jᵀ (∂T/∂G)ᵀ ŷ`; zero where the rod has no direction (gimbal on the pivot) or the
    /// angles are not finite: the PD and the safety layer deal with those poses.
    fn torque_nm(&self, q: &Joints) -> Joints {
        let (Ok(g), Ok(j)) = (
            phantom::forward(&self.phantom, q),
            phantom::jacobian(&self.phantom, q),
        ) else {
            return [0.0; 3];
        };
        let Ok(pose) = pivot::rod_pose(&self.pivot, &g) else {
            return [0.0; 3];
        };
        let u = pose.axis.into_inner();
        let a = self.pivot.rod_length_m - pose.depth_m;
        let k = 1.0 - self.pivot.rod_length_m / a;
        let up = Vector3::y();
        // (∂T/∂G)ᵀ ŷ = (u uᵀ + k (I − u uᵀ)) ŷ: the matrix is symmetric.
        let m = u * u.y + (up - u * u.y) * k;
        let tau = j.transpose() * (m * self.excess_n);
        if tau.iter().all(|t| t.is_finite()) {
            [tau.x, tau.y, tau.z]
        } else {
            [0.0; 3]
        }
    }
}

impl GravityModel for ArmGravity {
    fn torque_nm(&self, q: &Joints) -> Joints {
        let mut tau = self.bodies.torque_nm(q);
        if let Some(i) = &self.instrument {
            let extra = i.torque_nm(q);
            for (t, e) in tau.iter_mut().zip(extra) {
                *t += e;
            }
        }
        tau
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

    /// Height of the rod's tip for joint angles `q`.
    fn tip_height_m(phantom: &PhantomGeometry, pivot: &PivotGeometry, q: &Joints) -> f64 {
        let g = crate::kinematics::phantom::forward(phantom, q).unwrap();
        crate::kinematics::pivot::rod_pose(pivot, &g)
            .unwrap()
            .tip
            .0
            .y
    }

    /// The instrument's excess weight hangs at the tip: its holding torques are the gradient
    /// of the tip's height times the weight, on a leaning rod too; on a plumb rod, the
    /// gimbal Jacobian's height row times the weight.
    #[test]
    fn an_instruments_excess_weight_is_the_gradient_of_the_tips_height() {
        let (geom, piv) = (PhantomGeometry::default(), PivotGeometry::default());
        let m = PhantomMasses::default();
        let heavy = Instrument {
            mass_kg: 0.6,
            contact_load_n: 0.3 * 9.81,
        };
        let w = heavy.excess_weight_n(m.gravity_m_s2);
        assert!((w - 0.3 * 9.81).abs() < 1e-12);
        let bare = PhantomGravity::new(&m);
        let with = ArmGravity::new(&m, &geom, &piv, Some(&heavy));
        assert_eq!(with.instrument_excess_n(), w);
        // θ = (0, 0.5, 0.5) puts the gimbal plumb over the pivot; the others lean the rod.
        for q in [
            [0.0, 0.5, 0.5],
            [0.2, 0.5, 0.6],
            [-0.3, 0.4, 0.3],
            [0.1, 0.7, 0.8],
        ] {
            let (a, b) = (with.torque_nm(&q), bare.torque_nm(&q));
            let h = 1e-6;
            for k in 0..3 {
                let (mut qp, mut qm) = (q, q);
                qp[k] += h;
                qm[k] -= h;
                let fd = w * (tip_height_m(&geom, &piv, &qp) - tip_height_m(&geom, &piv, &qm))
                    / (2.0 * h);
                assert!(
                    (a[k] - b[k] - fd).abs() < 1e-6,
                    "joint {k} at {q:?}: {} vs {fd}",
                    a[k] - b[k]
                );
            }
        }
        // A pivot straight below the gimbal: the rod is plumb and the weight axial.
        let q = [0.0, 0.5, 0.5];
        let g = crate::kinematics::phantom::forward(&geom, &q).unwrap().0;
        let plumb = PivotGeometry {
            pivot_in_base_m: [g.x, g.y - 0.215, g.z],
            ..piv
        };
        let with_plumb = ArmGravity::new(&m, &geom, &plumb, Some(&heavy));
        let j = crate::kinematics::phantom::jacobian(&geom, &q).unwrap();
        let jt_f = j.transpose() * Vector3::new(0.0, w, 0.0);
        let (a, b) = (with_plumb.torque_nm(&q), bare.torque_nm(&q));
        for k in 0..3 {
            assert!((a[k] - b[k] - jt_f[k]).abs() < 1e-12, "joint {k}");
        }
        // Absent, no heavier than its contact load, or garbage: the bodies only.
        let q = [0.1, 0.4, 0.6];
        for i in [
            None,
            Some(Instrument {
                mass_kg: 0.2,
                contact_load_n: 2.943,
            }),
            Some(Instrument {
                mass_kg: f64::NAN,
                contact_load_n: 1.0,
            }),
            Some(Instrument {
                mass_kg: 0.3,
                contact_load_n: 0.3 * 9.81,
            }),
        ] {
            let g = ArmGravity::new(&m, &geom, &piv, i.as_ref());
            assert_eq!(g.torque_nm(&q), bare.torque_nm(&q), "{i:?}");
        }
        // Poses with no rod direction or no angles: nothing added, nothing non-finite.
        assert_eq!(with.torque_nm(&[f64::NAN, 0.0, 0.0])[0], 0.0);
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
