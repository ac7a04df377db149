//! Discrete-time stability of one joint under the PD loop: the closed-loop poles.
//!
//! A joint is modelled as a pure inertia J driven by a zero-order-held torque at the servo
//! period T (friction and the tissue only add damping). The loop closes through either the
//! measured joint rate or a backward difference of positions, with or without a cycle of
//! computation delay. The state is `[q_k, v_k, q_{k−1}, u_{k−1}]`:
//!
//! ```text
//! u_cmd  = −kp q_k − kd ω_k          ω_k = v_k  or  (q_k − q_{k−1}) / T
//! u      = u_cmd  or  u_{k−1}        (no delay / one cycle of delay)
//! q_k+1  = q_k + T v_k + T²/(2J) u,   v_k+1 = v_k + T/J u
//! ```
//!
//! The loop is stable when every eigenvalue lies strictly inside the unit circle. Not used
//! per cycle; the tests and docs/kinematics.md use it to choose and check the default gains.

use nalgebra::{Complex, Matrix4, RowVector4};

use crate::types::Joints;

/// How the rate fed to the D term is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RateSource {
    /// The true joint rate at the sample (an ideal tachometer or observer).
    Measured,
    /// (q_k − q_{k−1}) / T, what encoder-only drivers deliver.
    BackwardDifference,
}

/// One joint, its gains and the loop's timing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLoop {
    pub inertia_kg_m2: f64,
    pub kp_nm_per_rad: f64,
    pub kd_nm_s_per_rad: f64,
    pub period_s: f64,
    pub rate: RateSource,
    /// True if the torque computed from sample k is applied one period later.
    pub one_cycle_delay: bool,
}

/// Smallest inertia each joint can present, kg·m²: the bare Phantom's links (Cavusoglu et
/// al. 2002) plus the rotor's 1.03e-6 kg·m² reflected through the capstan (η² J_m), at the
/// lightest pose. See docs/kinematics.md for the arithmetic.
pub const JOINT_INERTIA_MIN_KG_M2: Joints = [1.5e-3, 2.5e-3, 1.0e-3];

/// Largest: the arm carrying the rod, sensor and the seed's 0.3 kg mass through the pivot,
/// whose inertia reflects to the joints through the lever, with margin.
pub const JOINT_INERTIA_MAX_KG_M2: Joints = [5e-2, 3e-2, 3e-2];

impl JointLoop {
    /// The closed-loop state-transition matrix.
    pub fn matrix(&self) -> Matrix4<f64> {
        let t = self.period_s;
        let (kp, kd) = (self.kp_nm_per_rad, self.kd_nm_s_per_rad);
        let command = match self.rate {
            RateSource::Measured => RowVector4::new(-kp, -kd, 0.0, 0.0),
            RateSource::BackwardDifference => RowVector4::new(-kp - kd / t, 0.0, kd / t, 0.0),
        };
        let applied = if self.one_cycle_delay {
            RowVector4::new(0.0, 0.0, 0.0, 1.0)
        } else {
            command
        };
        let b_q = t * t / (2.0 * self.inertia_kg_m2);
        let b_v = t / self.inertia_kg_m2;
        let mut a = Matrix4::zeros();
        a.set_row(0, &(RowVector4::new(1.0, t, 0.0, 0.0) + b_q * applied));
        a.set_row(1, &(RowVector4::new(0.0, 1.0, 0.0, 0.0) + b_v * applied));
        a.set_row(2, &RowVector4::new(1.0, 0.0, 0.0, 0.0));
        a.set_row(3, &command);
        a
    }

    pub fn poles(&self) -> [Complex<f64>; 4] {
        let e = self.matrix().complex_eigenvalues();
        [e[0], e[1], e[2], e[3]]
    }

    /// Largest pole magnitude: below 1 is stable.
    pub fn spectral_radius(&self) -> f64 {
        self.poles().iter().map(|z| z.norm()).fold(0.0, f64::max)
    }

    /// Smallest damping ratio of the poles mapped back to continuous time (s = ln z / T),
    /// ignoring the poles at the origin that the unused states contribute.
    pub fn min_damping_ratio(&self) -> f64 {
        self.poles()
            .iter()
            .filter(|z| z.norm() > 1e-9)
            .map(|z| {
                let s = z.ln() / self.period_s;
                -s.re / s.norm()
            })
            .fold(f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
#[path = "stability_tests.rs"]
mod tests;
