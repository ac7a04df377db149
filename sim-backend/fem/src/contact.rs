//! A rigid indenter ("finger") in frictionless contact with the top surface, solved by a
//! primal active-set method on the linear model.
//!
//! Small-deformation Signorini conditions on each top node i under the tip:
//! gap_i = (g(x_i - x_c) - δ) - u_y,i >= 0 (the surface stays below the tip), contact force λ_i >= 0, λ_i gap_i = 0, where g is
//! the tip's profile above its lowest point and δ the indentation. Active nodes get u_y
//! prescribed; the set is updated (release tensile nodes, add penetrating ones) until it no
//! longer changes. The pattern is fixed, so every iteration reuses the symbolic factorization.

use serde::{Deserialize, Serialize};

use super::linear::LinearModel;
use super::solve_error::SolveError;

/// The finger shapes of paper 002 (Fig. 13).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Tip {
    /// Flat with sharp corners.
    Rectangular { half_width_m: f64 },
    /// Flat with rounded corners of radius `fillet_radius_m` (< half width).
    Filleted {
        half_width_m: f64,
        fillet_radius_m: f64,
    },
    /// A circular arc of `radius_m`.
    Circular { radius_m: f64 },
    /// Half an ellipse, `semi_width_m` across and `semi_height_m` tall.
    Elliptical {
        semi_width_m: f64,
        semi_height_m: f64,
    },
}

impl Tip {
    /// The four fingers of paper 002's tip study (Fig. 13), 16 mm wide.
    pub const PAPER_002: [Tip; 4] = [
        Tip::Rectangular {
            half_width_m: 0.008,
        },
        Tip::Filleted {
            half_width_m: 0.008,
            fillet_radius_m: 0.002,
        },
        Tip::Circular { radius_m: 0.008 },
        Tip::Elliptical {
            semi_width_m: 0.008,
            semi_height_m: 0.004,
        },
    ];

    /// Height of the tip surface above its lowest point at lateral offset `x`; `None` where
    /// the tip does not reach (outside its width).
    pub fn profile(&self, x: f64) -> Option<f64> {
        let ax = x.abs();
        match *self {
            Tip::Rectangular { half_width_m } => (ax <= half_width_m).then_some(0.0),
            Tip::Filleted {
                half_width_m,
                fillet_radius_m: r,
            } => {
                if ax > half_width_m {
                    None
                } else {
                    let flat = half_width_m - r;
                    if ax <= flat {
                        Some(0.0)
                    } else {
                        let d = ax - flat;
                        Some(r - (r * r - d * d).max(0.0).sqrt())
                    }
                }
            }
            Tip::Circular { radius_m: r } => {
                (ax <= r).then(|| r - (r * r - ax * ax).max(0.0).sqrt())
            }
            Tip::Elliptical {
                semi_width_m: a,
                semi_height_m: b,
            } => (ax <= a).then(|| b * (1.0 - (1.0 - (ax / a).powi(2)).max(0.0).sqrt())),
        }
    }

    pub fn half_width_m(&self) -> f64 {
        match *self {
            Tip::Rectangular { half_width_m } | Tip::Filleted { half_width_m, .. } => half_width_m,
            Tip::Circular { radius_m } => radius_m,
            Tip::Elliptical { semi_width_m, .. } => semi_width_m,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Tip::Rectangular { .. } => "rectangular",
            Tip::Filleted { .. } => "filleted",
            Tip::Circular { .. } => "circular",
            Tip::Elliptical { .. } => "elliptical",
        }
    }

    pub fn is_valid(&self) -> bool {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        match *self {
            Tip::Rectangular { half_width_m } => pos(half_width_m),
            Tip::Filleted {
                half_width_m,
                fillet_radius_m,
            } => pos(half_width_m) && pos(fillet_radius_m) && fillet_radius_m <= half_width_m,
            Tip::Circular { radius_m } => pos(radius_m),
            Tip::Elliptical {
                semi_width_m,
                semi_height_m,
            } => pos(semi_width_m) && pos(semi_height_m),
        }
    }
}

/// The indenter's position: tip centre at lateral `centre_x_m`, lowest point `indent_m`
/// below the undeformed surface at height `surface_y_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Indenter {
    pub tip: Tip,
    pub centre_x_m: f64,
    pub indent_m: f64,
    pub surface_y_m: f64,
}

/// A converged contact state.
#[derive(Debug, Clone)]
pub struct ContactSolution {
    pub u: Vec<f64>,
    /// Per top node (mesh.top order): in contact or not.
    pub active: Vec<bool>,
    /// Per top node: contact force pushing the node down, N per m of thickness (>= 0).
    pub force_n_per_m: Vec<f64>,
    pub iterations: usize,
}

const MAX_ITERATIONS: usize = 200;
/// Relative tolerance on tension and penetration.
const TOL: f64 = 1e-9;

/// Solve the contact problem. `fixed`/`prescribed` hold the other supports (the top nodes'
/// y DOFs must be free in them); `force` the other loads.
pub fn solve_contact(
    model: &LinearModel<'_>,
    fixed: &[bool],
    prescribed: &[f64],
    force: &[f64],
    indenter: &Indenter,
) -> Result<ContactSolution, SolveError> {
    let mesh = model.mesh;
    let top = &mesh.top;
    // Target u_y of each top node if in contact (None: beyond the tip).
    let target: Vec<Option<f64>> = top
        .iter()
        .map(|&n| {
            let x = mesh.nodes[n as usize];
            indenter
                .tip
                .profile(x[0] - indenter.centre_x_m)
                .map(|g| (x[1] - indenter.surface_y_m) + g - indenter.indent_m)
        })
        .collect();
    let mut active: Vec<bool> = target
        .iter()
        .map(|t| matches!(t, Some(v) if *v < 0.0))
        .collect();
    let scale_u = indenter.indent_m.abs().max(1e-9);
    let mut seen: Vec<Vec<bool>> = Vec::new();
    let mut one_at_a_time = false;
    for it in 1..=MAX_ITERATIONS {
        let mut fx = fixed.to_vec();
        let mut pres = prescribed.to_vec();
        for (k, &n) in top.iter().enumerate() {
            if active[k] {
                let dof = 2 * n as usize + 1;
                fx[dof] = true;
                pres[dof] = target[k].unwrap_or(0.0);
            }
        }
        let c = model.factor(&fx)?;
        let u = c.solve(force, &pres)?;
        let r = c.reactions(&u, force);
        let r_scale = r.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-30);
        // Release the nodes the tip would have to pull; add the ones that penetrate. After a
        // cycle is seen, change one node per iteration (the worst violation), which is slower
        // but cannot oscillate between two sets.
        let mut next = active.clone();
        let mut worst: Option<(usize, f64)> = None;
        for (k, &n) in top.iter().enumerate() {
            let dof = 2 * n as usize + 1;
            let violation = if active[k] {
                r[dof] / r_scale - TOL
            } else if let Some(t) = target[k] {
                (u[dof] - t) / scale_u - TOL
            } else {
                0.0
            };
            if violation > 0.0 {
                if one_at_a_time {
                    if worst.is_none_or(|(_, v)| violation > v) {
                        worst = Some((k, violation));
                    }
                } else {
                    next[k] = !active[k];
                }
            }
        }
        if let Some((k, _)) = worst {
            next[k] = !active[k];
        }
        if next == active {
            let force_n_per_m = top
                .iter()
                .zip(&active)
                .map(|(&n, &a)| {
                    if a {
                        (-r[2 * n as usize + 1]).max(0.0)
                    } else {
                        0.0
                    }
                })
                .collect();
            return Ok(ContactSolution {
                u,
                active,
                force_n_per_m,
                iterations: it,
            });
        }
        if seen.contains(&next) {
            if one_at_a_time {
                return Err(SolveError::NoConvergence(format!(
                    "contact active set cycles after {it} iterations"
                )));
            }
            one_at_a_time = true;
            continue;
        }
        seen.push(active);
        active = next;
    }
    Err(SolveError::NoConvergence(format!(
        "contact active set did not settle in {MAX_ITERATIONS} iterations"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Analysis, Material};
    use crate::mesher::test_artery_block;

    #[test]
    fn tip_profiles() {
        let c = Tip::Circular { radius_m: 2.0 };
        assert_eq!(c.profile(0.0), Some(0.0));
        assert!((c.profile(2.0).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(c.profile(2.1), None);
        let f = Tip::Filleted {
            half_width_m: 3.0,
            fillet_radius_m: 1.0,
        };
        assert_eq!(f.profile(1.9), Some(0.0));
        assert!((f.profile(3.0).unwrap() - 1.0).abs() < 1e-12);
        let e = Tip::Elliptical {
            semi_width_m: 2.0,
            semi_height_m: 1.0,
        };
        assert!((e.profile(2.0).unwrap() - 1.0).abs() < 1e-12);
        assert!(e.profile(1.0).unwrap() < c.profile(1.0).unwrap());
    }

    fn setup(pressure_pa: f64) -> (crate::mesh::Mesh, Vec<Material>, f64) {
        let m = test_artery_block(0.006, 0.0026, 0.0006, 0.002);
        (
            m,
            vec![Material::new(50e3, 0.45), Material::new(400e3, 0.49)],
            pressure_pa,
        )
    }

    fn supports(m: &crate::mesh::Mesh) -> (Vec<bool>, Vec<f64>) {
        let mut fixed = vec![false; m.dofs()];
        for &n in &m.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * m.bottom[m.bottom.len() / 2] as usize] = true;
        (fixed, vec![0.0; m.dofs()])
    }

    #[test]
    fn contact_closes_with_indentation_and_opens_on_retraction() {
        let (m, mats, p) = setup(16e3);
        let lm = LinearModel::new(&m, &mats, Analysis::PlaneStress).unwrap();
        let (fixed, pres) = supports(&m);
        let force = m.lumen_pressure_forces(p);
        let tip = Tip::Circular { radius_m: 0.008 };
        let mut widths = Vec::new();
        for indent in [0.0005, 0.0015, 0.003] {
            let ind = Indenter {
                tip,
                centre_x_m: 0.02,
                indent_m: indent,
                surface_y_m: 0.02,
            };
            let s = solve_contact(&lm, &fixed, &pres, &force, &ind).unwrap();
            // Signorini: no penetration, compressive forces only.
            for (k, &n) in m.top.iter().enumerate() {
                let x = m.nodes[n as usize];
                if let Some(g) = tip.profile(x[0] - 0.02) {
                    assert!(s.u[2 * n as usize + 1] <= g - indent + 1e-9 * indent);
                }
                assert!(s.force_n_per_m[k] >= 0.0);
            }
            let xs: Vec<f64> = m
                .top
                .iter()
                .zip(&s.active)
                .filter(|(_, a)| **a)
                .map(|(&n, _)| m.nodes[n as usize][0])
                .collect();
            let width = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - xs.iter().cloned().fold(f64::INFINITY, f64::min);
            widths.push(width);
            // The contact is a proper subset of the tip: it opened at its edges.
            assert!(width < 2.0 * 0.008 * 0.95, "width {width}");
        }
        assert!(widths[0] < widths[1] && widths[1] < widths[2], "{widths:?}");
        // Retract: the pressurized tube pushes the surface up but nothing holds it down.
        let ind = Indenter {
            tip,
            centre_x_m: 0.02,
            indent_m: -0.0005,
            surface_y_m: 0.02,
        };
        let s = solve_contact(&lm, &fixed, &pres, &force, &ind).unwrap();
        assert!(s.active.iter().all(|a| !a));
        assert!(s.force_n_per_m.iter().all(|&f| f == 0.0));
    }

    #[test]
    fn a_flat_punch_starting_fully_active_releases_nodes_lifted_by_the_tube() {
        // Tiny indentation, large lumen pressure: the bulge over the tube must stay in
        // contact while nodes released by tension are set free; the total force balances.
        let (m, mats, p) = setup(60e3);
        let lm = LinearModel::new(&m, &mats, Analysis::PlaneStress).unwrap();
        let (fixed, pres) = supports(&m);
        let force = m.lumen_pressure_forces(p);
        let ind = Indenter {
            tip: Tip::Rectangular {
                half_width_m: 0.012,
            },
            centre_x_m: 0.02,
            indent_m: 1e-6,
            surface_y_m: 0.02,
        };
        let s = solve_contact(&lm, &fixed, &pres, &force, &ind).unwrap();
        let n_active = s.active.iter().filter(|a| **a).count();
        let n_under = m
            .top
            .iter()
            .filter(|&&n| (m.nodes[n as usize][0] - 0.02).abs() <= 0.012)
            .count();
        assert!(
            n_active > 0 && n_active < n_under,
            "{n_active} of {n_under}"
        );
        assert!(s.iterations > 1);
    }
}
