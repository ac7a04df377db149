//! The sensor on the tissue: normal force from indentation, and sliding friction with the
//! surface's shear compliance before it slides (an elasto-plastic, "bristle" contact).
//!
//! Laterally the sensor is held between two springs in series: the rod and pivot (compliance
//! `c`, pulling it toward where a rigid rod would put it, `x_rigid`) and the tissue surface's
//! shear (`k_s`, pulling it toward the anchor `x_a`, where the surface under it last stuck).
//! Both are massless (see [`super::rod`]), so the sensor sits where the springs balance:
//!
//! ```text
//! x = (x_rigid + c F_other + c k_s x_a) / (1 + c k_s)
//! ```
//!
//! While the spring force stays within `μ_s N` the contact sticks; past it the anchor slides
//! so that the force is `μ_k N`, until the pull falls back under `μ_k N`. The sensor's true
//! position therefore lags the robot's rigid-rod belief by `c · F`, and when the arm stops
//! that lag stays, held by static friction: the seed's unmodelled compliance.

use crate::scene::{FrictionSpec, TissueSpec};

/// A 2-D vector on the tissue plane (`x`, `z`).
pub type Plane = [f64; 2];

fn norm(v: Plane) -> f64 {
    v[0].hypot(v[1])
}

/// The state of the contact between steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactState {
    /// Where the tissue surface under the sensor is stuck; `None` when not touching.
    pub anchor: Option<Plane>,
    pub sliding: bool,
    /// Indentation at the previous step, for the damping term.
    pub previous_indentation_m: f64,
    /// The rigid-rod sensor position at the previous step, for the shear damping.
    pub previous_rigid: Option<Plane>,
}

impl Default for ContactState {
    fn default() -> Self {
        Self {
            anchor: None,
            sliding: false,
            previous_indentation_m: 0.0,
            previous_rigid: None,
        }
    }
}

/// The result of one contact solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactSolution {
    /// Normal force on the sensor, N.
    pub normal_n: f64,
    pub indentation_m: f64,
    /// Where the sensor truly is on the tissue plane.
    pub position: Plane,
    /// The tissue's lateral (friction) force on the sensor, N.
    pub friction_n: Plane,
    pub sliding: bool,
}

/// The tissue contact model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TissueContact {
    stiffness: f64,
    damping: f64,
    friction: Option<FrictionSpec>,
    /// Shear damping (the foam's viscous loss), N·s/m.
    shear_damping: f64,
}

impl TissueContact {
    pub fn new(tissue: &TissueSpec) -> Self {
        Self {
            stiffness: tissue.contact_stiffness_n_per_m,
            damping: tissue.contact_damping_n_s_per_m,
            friction: tissue.friction,
            // The same loss factor in shear as in compression: damping scales with
            // stiffness by the normal contact's ratio.
            shear_damping: tissue.friction.map_or(0.0, |f| {
                f.shear_stiffness_n_per_m * tissue.contact_damping_n_s_per_m
                    / tissue.contact_stiffness_n_per_m
            }),
        }
    }

    /// Solve the contact for one step of `dt_s`.
    ///
    /// `rigid` is where a rigid rod would put the sensor, `height_m` the sensor's bottom
    /// edge above the surface (negative: indenting), `compliance` the rod's lateral tip
    /// compliance (m/N), and `other` the other lateral loads on the tip in the tissue plane
    /// (the normal force and weight on a tilted rod), N.
    pub fn solve(
        &self,
        state: &mut ContactState,
        rigid: Plane,
        height_m: f64,
        compliance: f64,
        other: Plane,
        dt_s: f64,
    ) -> ContactSolution {
        let indentation = (-height_m).max(0.0);
        let rate = (indentation - state.previous_indentation_m) / dt_s;
        state.previous_indentation_m = indentation;
        let rigid_rate = state.previous_rigid.map_or([0.0; 2], |p| {
            [(rigid[0] - p[0]) / dt_s, (rigid[1] - p[1]) / dt_s]
        });
        state.previous_rigid = Some(rigid);
        let normal = if indentation > 0.0 {
            (self.stiffness * indentation + self.damping * rate).max(0.0)
        } else {
            0.0
        };
        let free = [
            rigid[0] + compliance * other[0],
            rigid[1] + compliance * other[1],
        ];
        let (Some(f), true) = (self.friction, normal > 0.0) else {
            // No friction, or not touching: the sensor is where the loads put it and the
            // surface will stick wherever it next touches.
            state.anchor = if normal > 0.0 { Some(free) } else { None };
            state.sliding = false;
            return ContactSolution {
                normal_n: normal,
                indentation_m: indentation,
                position: free,
                friction_n: [0.0; 2],
                sliding: false,
            };
        };
        let anchor = *state.anchor.get_or_insert(free);
        let k_s = f.shear_stiffness_n_per_m;
        // Rod and surface in series: stiffness from the free position to the anchor.
        let k_eff = 1.0 / (1.0 / k_s + compliance);
        let w = [free[0] - anchor[0], free[1] - anchor[1]];
        let stuck_force = [
            -k_eff * w[0] - self.shear_damping * rigid_rate[0],
            -k_eff * w[1] - self.shear_damping * rigid_rate[1],
        ];
        let limit = if state.sliding {
            f.kinetic_coefficient * normal
        } else {
            f.static_coefficient * normal
        };
        let pull = norm(stuck_force);
        let (force, sliding) = if pull <= limit {
            (stuck_force, false)
        } else {
            let k = f.kinetic_coefficient * normal / pull;
            ([stuck_force[0] * k, stuck_force[1] * k], true)
        };
        let position = [
            free[0] + compliance * force[0],
            free[1] + compliance * force[1],
        ];
        if sliding {
            // The surface slid: re-anchor so the shear spring carries exactly the force.
            state.anchor = Some([position[0] + force[0] / k_s, position[1] + force[1] / k_s]);
        }
        state.sliding = sliding;
        ContactSolution {
            normal_n: normal,
            indentation_m: indentation,
            position,
            friction_n: force,
            sliding,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn foam(friction: bool) -> TissueContact {
        TissueContact::new(&TissueSpec {
            contact_stiffness_n_per_m: 1000.0,
            contact_damping_n_s_per_m: 0.0,
            friction: friction.then_some(FrictionSpec {
                static_coefficient: 0.6,
                kinetic_coefficient: 0.5,
                shear_stiffness_n_per_m: 2000.0,
            }),
            breathing: None,
            placement_error: None,
        })
    }

    #[test]
    fn normal_force_from_indentation() {
        let c = foam(false);
        let mut s = ContactState::default();
        let sol = c.solve(&mut s, [0.0; 2], -0.003, 0.0, [0.0; 2], 1e-3);
        assert!((sol.normal_n - 3.0).abs() < 1e-9);
        let sol = c.solve(&mut s, [0.0; 2], 0.001, 0.0, [0.0; 2], 1e-3);
        assert_eq!(sol.normal_n, 0.0);
    }

    #[test]
    fn dragging_a_compliant_rod_lags_then_slides_then_keeps_the_lag() {
        let c = foam(true);
        let mut s = ContactState::default();
        let compliance = 0.004; // m/N
        let n_dt = 1e-3;
        // Drag the rigid position 30 mm along x at constant indentation 3 mm (N = 3 N).
        let mut last = None;
        for i in 0..=3000 {
            let x = i as f64 * 1e-5;
            last = Some(c.solve(&mut s, [x, 0.0], -0.003, compliance, [0.0; 2], n_dt));
        }
        let sol = last.unwrap();
        assert!(sol.sliding);
        // Sliding: the friction is μ_k N = 1.5 N against the motion; the sensor lags by c F.
        assert!((sol.friction_n[0] + 1.5).abs() < 1e-6, "{sol:?}");
        assert!((0.03 - sol.position[0] - compliance * 1.5).abs() < 1e-6);
        // Stop: the lag stays, held by static friction.
        for _ in 0..1000 {
            let held = c.solve(&mut s, [0.03, 0.0], -0.003, compliance, [0.0; 2], n_dt);
            assert!(!held.sliding);
            assert!((0.03 - held.position[0] - 0.006).abs() < 1e-6);
        }
    }

    #[test]
    fn rigid_rod_sensor_is_where_the_robot_thinks() {
        let c = foam(true);
        let mut s = ContactState::default();
        for i in 0..=2000 {
            let x = i as f64 * 1e-5;
            let sol = c.solve(&mut s, [x, 0.0], -0.003, 0.0, [0.0; 2], 1e-3);
            assert!((sol.position[0] - x).abs() < 1e-15);
        }
    }

    #[test]
    fn lifting_off_releases_the_contact() {
        let c = foam(true);
        let mut s = ContactState::default();
        c.solve(&mut s, [0.0, 0.0], -0.003, 0.004, [0.0; 2], 1e-3);
        c.solve(&mut s, [0.002, 0.0], -0.003, 0.004, [0.0; 2], 1e-3);
        let sol = c.solve(&mut s, [0.002, 0.0], 0.001, 0.004, [0.0; 2], 1e-3);
        assert_eq!(sol.normal_n, 0.0);
        assert_eq!(sol.position, [0.002, 0.0]);
        assert!(s.anchor.is_none());
    }
}
