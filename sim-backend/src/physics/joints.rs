//! The Phantom's joints: rigid-body dynamics under torque with Coulomb and viscous friction,
//! hard stops, and encoders that quantize what the robot reads.

use control::types::Joints;
use nalgebra::{Matrix3, Vector3};

use crate::scene::RobotSpec;

/// Below this joint speed a joint whose net torque is within its Coulomb friction sticks
/// (Karnopp's stick band), rad/s.
const STICK_SPEED_RAD_S: f64 = 1e-3;

/// Joint state integrated at the servo rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDynamics {
    pub q: Joints,
    pub qd: Joints,
    inertia: [f64; 3],
    coulomb: [f64; 3],
    viscous: [f64; 3],
    /// Hard stops: (min, max) per joint.
    stops: [(f64, f64); 3],
}

impl JointDynamics {
    pub fn new(spec: &RobotSpec, q0: Joints, stops: [(f64, f64); 3]) -> Self {
        Self {
            q: q0,
            qd: [0.0; 3],
            inertia: spec.joint_inertia_kg_m2,
            coulomb: spec.coulomb_friction_nm,
            viscous: spec.viscous_friction_nm_s,
            stops,
        }
    }

    /// Advance by `dt_s` under the net external joint torque `tau` (motors, gravity, the
    /// rod), with `extra_mass` the configuration-dependent inertia the rod adds (Jᵀ M J).
    /// Semi-implicit Euler: velocities first, then positions with the new velocities.
    pub fn step(&mut self, tau: &Joints, extra_mass: &Matrix3<f64>, dt_s: f64) {
        let mut m = *extra_mass;
        for i in 0..3 {
            m[(i, i)] += self.inertia[i];
        }
        let mut rhs = Vector3::zeros();
        let mut stuck = [false; 3];
        for i in 0..3 {
            let driving = tau[i] - self.viscous[i] * self.qd[i];
            if self.qd[i].abs() < STICK_SPEED_RAD_S && driving.abs() <= self.coulomb[i] {
                stuck[i] = true;
            } else {
                let dir = if self.qd[i].abs() >= STICK_SPEED_RAD_S {
                    self.qd[i].signum()
                } else {
                    driving.signum()
                };
                rhs[i] = driving - self.coulomb[i] * dir;
            }
        }
        // Stuck joints do not accelerate: replace their rows by q̈_i = 0.
        for (i, &s) in stuck.iter().enumerate() {
            if s {
                for j in 0..3 {
                    m[(i, j)] = if i == j { 1.0 } else { 0.0 };
                }
                rhs[i] = 0.0;
            }
        }
        let qdd = m.lu().solve(&rhs).unwrap_or_else(Vector3::zeros);
        for i in 0..3 {
            let before = self.qd[i];
            let mut after = if stuck[i] {
                0.0
            } else {
                before + qdd[i] * dt_s
            };
            // Friction can stop a joint but never reverse it within a step.
            if !stuck[i] && before != 0.0 && after.signum() != before.signum() {
                let driving = tau[i] - self.viscous[i] * after;
                if driving.abs() <= self.coulomb[i] {
                    after = 0.0;
                }
            }
            self.qd[i] = after;
            self.q[i] += after * dt_s;
            let (lo, hi) = self.stops[i];
            if self.q[i] < lo {
                self.q[i] = lo;
                self.qd[i] = self.qd[i].max(0.0);
            } else if self.q[i] > hi {
                self.q[i] = hi;
                self.qd[i] = self.qd[i].min(0.0);
            }
        }
    }
}

/// Incremental encoders on the motors, read through the capstans, with a filtered
/// difference for velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Encoders {
    rad_per_count: [f64; 3],
    filter_s: f64,
    last_counts: Option<[i64; 3]>,
    velocity: Joints,
}

impl Encoders {
    pub fn new(spec: &RobotSpec) -> Self {
        let mut rad_per_count = [0.0; 3];
        for (r, ratio) in rad_per_count.iter_mut().zip(spec.capstan_ratio) {
            *r = std::f64::consts::TAU / (spec.encoder_counts_per_rev * ratio);
        }
        Self {
            rad_per_count,
            filter_s: spec.velocity_filter_s,
            last_counts: None,
            velocity: [0.0; 3],
        }
    }

    /// Joint resolution, rad per count.
    pub fn resolution_rad(&self) -> [f64; 3] {
        self.rad_per_count
    }

    fn counts(&self, q: &Joints) -> [i64; 3] {
        let mut c = [0i64; 3];
        for i in 0..3 {
            c[i] = (q[i] / self.rad_per_count[i]).floor() as i64;
        }
        c
    }

    /// Sample the encoders at the true angles `q` after a step of `dt_s`; updates the
    /// velocity estimate.
    pub fn sample(&mut self, q: &Joints, dt_s: f64) {
        let counts = self.counts(q);
        if let Some(last) = self.last_counts {
            let alpha = if self.filter_s > 0.0 {
                dt_s / (self.filter_s + dt_s)
            } else {
                1.0
            };
            for i in 0..3 {
                let raw = (counts[i] - last[i]) as f64 * self.rad_per_count[i] / dt_s;
                self.velocity[i] += alpha * (raw - self.velocity[i]);
            }
        }
        self.last_counts = Some(counts);
    }

    /// The measured angles (the centre of the current count) and filtered velocity.
    pub fn read(&self, q: &Joints) -> (Joints, Joints) {
        let counts = self.last_counts.unwrap_or_else(|| self.counts(q));
        let mut out = [0.0; 3];
        for i in 0..3 {
            out[i] = (counts[i] as f64 + 0.5) * self.rad_per_count[i];
        }
        (out, self.velocity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> RobotSpec {
        RobotSpec::default()
    }

    #[test]
    fn torque_accelerates_as_inertia_says() {
        let mut s = spec();
        s.coulomb_friction_nm = [0.0; 3];
        s.viscous_friction_nm_s = [0.0; 3];
        let mut j = JointDynamics::new(&s, [0.0; 3], [(-3.0, 3.0); 3]);
        for _ in 0..100 {
            j.step(&[0.01, 0.0, 0.0], &Matrix3::zeros(), 1e-3);
        }
        // ω = τ t / I after 0.1 s.
        let expect = 0.01 * 0.1 / s.joint_inertia_kg_m2[0];
        assert!(
            (j.qd[0] - expect).abs() < 1e-9 * expect.max(1.0),
            "{:?}",
            j.qd
        );
        assert_eq!(j.qd[1], 0.0);
    }

    #[test]
    fn coulomb_friction_holds_small_torques_and_stops_motion() {
        let s = spec();
        let mut j = JointDynamics::new(&s, [0.0; 3], [(-3.0, 3.0); 3]);
        for _ in 0..1000 {
            j.step(
                &[0.5 * s.coulomb_friction_nm[0], 0.0, 0.0],
                &Matrix3::zeros(),
                1e-3,
            );
        }
        assert_eq!(j.q[0], 0.0);
        j.qd = [1.0, 0.0, 0.0];
        for _ in 0..5000 {
            j.step(&[0.0; 3], &Matrix3::zeros(), 1e-3);
        }
        assert_eq!(
            j.qd[0], 0.0,
            "friction stops a coasting joint and does not reverse it"
        );
    }

    #[test]
    fn hard_stops_hold() {
        let s = spec();
        let mut j = JointDynamics::new(&s, [0.0; 3], [(-0.1, 0.1); 3]);
        for _ in 0..2000 {
            j.step(&[0.2, -0.2, 0.0], &Matrix3::zeros(), 1e-3);
        }
        assert_eq!(j.q[0], 0.1);
        assert_eq!(j.q[1], -0.1);
    }

    #[test]
    fn encoders_quantize_to_1024_counts_through_the_capstan() {
        let s = spec();
        let mut e = Encoders::new(&s);
        let r = e.resolution_rad();
        assert!((r[0] - std::f64::consts::TAU / (1024.0 * 13.3)).abs() < 1e-15);
        let q = [0.3 * r[0], 1.7 * r[1], -0.2 * r[2]];
        e.sample(&q, 1e-3);
        let (m, _) = e.read(&q);
        assert!((m[0] - 0.5 * r[0]).abs() < 1e-15);
        assert!((m[1] - 1.5 * r[1]).abs() < 1e-15);
        assert!((m[2] + 0.5 * r[2]).abs() < 1e-15);
        // Moving at a steady rate, the filtered velocity converges to it.
        let mut e = Encoders::new(&s);
        let w = 0.2;
        for k in 0..2000 {
            e.sample(&[w * k as f64 * 1e-3, 0.0, 0.0], 1e-3);
        }
        let (_, v) = e.read(&[0.0; 3]);
        assert!((v[0] - w).abs() < 0.05 * w, "{v:?}");
    }
}
