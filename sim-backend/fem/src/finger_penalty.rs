//! The rigid finger in frictionless contact in finite strain: a penalty on the gap between
//! each top node's *current* position and the tip surface.
//!
//! The tip surface is the graph y_tip(x) = surface - δ + p(x - x_c) of its profile p. For a
//! node at the current (x, y) the gap is g = y_tip(x) - y; where g < 0 the energy
//! ε/2 g² pushes the node out along ∇g = (p'(x), -1), which is the tip's normal: the
//! contact force has no tangential part (frictionless), and the node may slide along the
//! tip as the tissue deforms. Tangent: ε ∇g ∇gᵀ. The exact tangent has a further
//! ε g p'' e_x e_xᵀ, negative under a convex tip; while a Newton predictor penetrates by a
//! whole load step it outweighs the tissue's own stiffness and the factorization fails, and
//! at equilibrium it is only (contact force)/(tip radius), so it is left out (Newton
//! converges a little slower, to the same solution).
//!
//! Flanks steeper than `MAX_SLOPE` (the last 0.5 % of an ellipse's or a fillet's width,
//! where p' → ∞) are continued by their tangent line, so the tip stays within its width and
//! the force direction stays bounded. Outside the tip's width there is no contact (as in the
//! small-strain solver): the finger's vertical sides are not modelled.

use super::contact::Tip;
use super::mesh::Mesh;
use super::sparse::Pattern;

/// Steepest flank slope represented (dy/dx = 5, 79°).
pub const MAX_SLOPE: f64 = 5.0;

/// Penalty stiffness per unit of the tissue's Young's modulus: a node pushed with the
/// stress E over an element size h penetrates by about h/1000.
pub const PENALTY_PER_MODULUS: f64 = 1e3;

/// Height above the lowest point, slope and second derivative of the tip surface at
/// lateral offset `x` from its centre; `None` outside its width.
pub fn tip_surface(tip: &Tip, x: f64) -> Option<[f64; 3]> {
    let ax = x.abs();
    let sign = if x < 0.0 { -1.0 } else { 1.0 };
    // An arc of radius r starting flat at offset `flat`: p = r - sqrt(r² - d²).
    let arc = |d: f64, r: f64| -> [f64; 3] {
        let d_cap = r * MAX_SLOPE / (1.0 + MAX_SLOPE * MAX_SLOPE).sqrt();
        let at = |d: f64| {
            let s = (r * r - d * d).sqrt();
            [r - s, d / s, r * r / (s * s * s)]
        };
        if d <= d_cap {
            at(d)
        } else {
            let p = at(d_cap)[0];
            [p + MAX_SLOPE * (d - d_cap), MAX_SLOPE, 0.0]
        }
    };
    let [p, p1, p2] = match *tip {
        Tip::Rectangular { half_width_m } => {
            if ax > half_width_m {
                return None;
            }
            [0.0, 0.0, 0.0]
        }
        Tip::Filleted {
            half_width_m,
            fillet_radius_m: r,
        } => {
            if ax > half_width_m {
                return None;
            }
            let flat = half_width_m - r;
            if ax <= flat {
                [0.0, 0.0, 0.0]
            } else {
                arc(ax - flat, r)
            }
        }
        Tip::Circular { radius_m: r } => {
            if ax > r {
                return None;
            }
            arc(ax, r)
        }
        Tip::Elliptical {
            semi_width_m: a,
            semi_height_m: b,
        } => {
            if ax > a {
                return None;
            }
            // p = b (1 - sqrt(1 - t²)), t = x/a; p' = (b/a) t / sqrt(1 - t²).
            let k = MAX_SLOPE * a / b;
            let t_cap = k / (1.0 + k * k).sqrt();
            let at = |t: f64| {
                let s = (1.0 - t * t).sqrt();
                [b * (1.0 - s), b / a * t / s, b / (a * a * s * s * s)]
            };
            let t = ax / a;
            if t <= t_cap {
                at(t)
            } else {
                let p = at(t_cap)[0];
                [p + MAX_SLOPE * (ax - t_cap * a), MAX_SLOPE, 0.0]
            }
        }
    };
    Some([p, sign * p1, p2])
}

/// The finger against the top surface of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FingerPenalty {
    pub tip: Tip,
    pub centre_x_m: f64,
    /// Height of the undeformed surface.
    pub surface_y_m: f64,
    /// ε, N/m per m of penetration per m of thickness (Pa).
    pub penalty_pa: f64,
}

/// One top node in contact: its gap (negative) and the gap's slope along x.
struct Touch {
    node: usize,
    g: f64,
    gx: f64,
}

impl FingerPenalty {
    /// Top nodes under the tip (mesh.top index, node, gap, slope) at displacement `u`.
    fn gaps<'a>(
        &'a self,
        mesh: &'a Mesh,
        u: &'a [f64],
        indent_m: f64,
    ) -> impl Iterator<Item = (usize, Touch)> + 'a {
        mesh.top.iter().enumerate().filter_map(move |(k, &n)| {
            let n = n as usize;
            let x = mesh.nodes[n][0] + u[2 * n];
            let y = mesh.nodes[n][1] + u[2 * n + 1];
            let [p, p1, _] = tip_surface(&self.tip, x - self.centre_x_m)?;
            let g = self.surface_y_m - indent_m + p - y;
            Some((k, Touch { node: n, g, gx: p1 }))
        })
    }

    fn touches<'a>(
        &'a self,
        mesh: &'a Mesh,
        u: &'a [f64],
        indent_m: f64,
    ) -> impl Iterator<Item = Touch> + 'a {
        self.gaps(mesh, u, indent_m)
            .filter_map(|(_, t)| (t.g < 0.0).then_some(t))
    }

    /// Top nodes (mesh.top order) not in contact at `u` whose gap, linearized at `u`, the
    /// step `du` would close: a Newton step that ignores them would throw them deep into
    /// the tip (the penalty has no stiffness until contact).
    pub fn closing(&self, mesh: &Mesh, u: &[f64], du: &[f64], indent_m: f64) -> Vec<bool> {
        let mut out = vec![false; mesh.top.len()];
        for (k, t) in self.gaps(mesh, u, indent_m) {
            let n = t.node;
            out[k] = t.g >= 0.0 && t.g + t.gx * du[2 * n] - du[2 * n + 1] < 0.0;
        }
        out
    }

    /// Add the linearized penalty of nodes flagged in `extra` (mesh.top order) that are not
    /// in contact: force ε g ∇g and stiffness ε ∇g ∇gᵀ, the branch they are about to enter.
    #[allow(clippy::too_many_arguments)]
    pub fn add_closing(
        &self,
        mesh: &Mesh,
        pattern: &Pattern,
        u: &[f64],
        indent_m: f64,
        extra: &[bool],
        fint: &mut [f64],
        values: &mut [f64],
    ) {
        let eps = self.penalty_pa;
        for (k, t) in self.gaps(mesh, u, indent_m) {
            if t.g >= 0.0 && extra.get(k).copied().unwrap_or(false) {
                fint[2 * t.node] += eps * t.g * t.gx;
                fint[2 * t.node + 1] -= eps * t.g;
                let [xx, yx, yy] = pattern.node_block(t.node);
                values[xx] += eps * t.gx * t.gx;
                values[yx] -= eps * t.gx;
                values[yy] += eps;
            }
        }
    }

    /// Add the contact's resisting forces to `fint` and its tangent to the assembled values.
    pub fn add(
        &self,
        mesh: &Mesh,
        pattern: &Pattern,
        u: &[f64],
        indent_m: f64,
        fint: &mut [f64],
        values: &mut [f64],
    ) {
        let eps = self.penalty_pa;
        for t in self.touches(mesh, u, indent_m) {
            fint[2 * t.node] += eps * t.g * t.gx;
            fint[2 * t.node + 1] -= eps * t.g;
            let [xx, yx, yy] = pattern.node_block(t.node);
            values[xx] += eps * t.gx * t.gx;
            values[yx] -= eps * t.gx;
            values[yy] += eps;
        }
    }

    /// Per top node (mesh.top order): the contact force's downward component, N per m of
    /// thickness (>= 0), and the deepest penetration, m.
    pub fn forces(&self, mesh: &Mesh, u: &[f64], indent_m: f64) -> (Vec<f64>, f64) {
        let mut by_node = vec![0.0; mesh.nodes.len()];
        let mut deepest = 0.0f64;
        for t in self.touches(mesh, u, indent_m) {
            by_node[t.node] = -self.penalty_pa * t.g;
            deepest = deepest.max(-t.g);
        }
        (
            mesh.top.iter().map(|&n| by_node[n as usize]).collect(),
            deepest,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surfaces_match_the_profiles_and_their_derivatives() {
        let tips = Tip::PAPER_002;
        for tip in tips {
            let hw = tip.half_width_m();
            assert!(tip_surface(&tip, 1.001 * hw).is_none());
            let h = 1e-7;
            for i in -19..=19 {
                // Away from the capped flank (the last 2 % of the width).
                let x = 0.049 * hw * f64::from(i);
                let s = tip_surface(&tip, x).unwrap();
                let p = tip.profile(x).unwrap();
                assert!((s[0] - p).abs() < 1e-12, "{tip:?} at {x}: {} vs {p}", s[0]);
                let sp = tip_surface(&tip, x + h).unwrap();
                let sm = tip_surface(&tip, x - h).unwrap();
                let fd1 = (sp[0] - sm[0]) / (2.0 * h);
                let fd2 = (sp[1] - sm[1]) / (2.0 * h);
                assert!(
                    (fd1 - s[1]).abs() < 1e-6 * (1.0 + s[1].abs()),
                    "{tip:?} slope at {x}"
                );
                assert!(
                    (fd2 - s[2]).abs() < 1e-4 * (1.0 + s[2].abs()),
                    "{tip:?} curvature at {x}"
                );
            }
            // Symmetric, and the capped flank is continuous and no steeper than the cap.
            let edge = tip_surface(&tip, 0.9999 * hw).unwrap();
            assert!(edge[1].abs() <= MAX_SLOPE + 1e-12);
            let mirrored = tip_surface(&tip, -0.9999 * hw).unwrap();
            assert!((edge[0] - mirrored[0]).abs() < 1e-15 && (edge[1] + mirrored[1]).abs() < 1e-12);
        }
        // The ellipse's flank cap starts where the slope reaches MAX_SLOPE: continuous there.
        let e = Tip::Elliptical {
            semi_width_m: 0.008,
            semi_height_m: 0.004,
        };
        let k = MAX_SLOPE * 2.0;
        let xc = 0.008 * k / (1.0 + k * k).sqrt();
        let below = tip_surface(&e, xc - 1e-12).unwrap();
        let above = tip_surface(&e, xc + 1e-12).unwrap();
        assert!((below[0] - above[0]).abs() < 1e-10);
        assert!((below[1] - MAX_SLOPE).abs() < 1e-6 && (above[1] - MAX_SLOPE).abs() < 1e-12);
    }

    use crate::contact::{Indenter, solve_contact};
    use crate::finite::FiniteModel;
    use crate::linear::LinearModel;
    use crate::material::{Analysis, Material};
    use crate::mesher::test_artery_block;

    const TISSUE_PA: f64 = 50e3;

    fn artery() -> (Mesh, Vec<Material>) {
        let m = test_artery_block(0.006, 0.0026, 0.0006, 0.002);
        (
            m,
            vec![Material::new(TISSUE_PA, 0.45), Material::new(400e3, 0.49)],
        )
    }

    fn supports(m: &Mesh) -> Vec<bool> {
        let mut fixed = vec![false; m.dofs()];
        for &n in &m.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * m.bottom[m.bottom.len() / 2] as usize] = true;
        fixed
    }

    fn finger() -> FingerPenalty {
        FingerPenalty {
            tip: Tip::Circular { radius_m: 0.008 },
            centre_x_m: 0.02,
            surface_y_m: 0.02,
            penalty_pa: PENALTY_PER_MODULUS * TISSUE_PA,
        }
    }

    /// Finite-strain and linear contact at one indentation and lumen pressure: relative
    /// difference of the total contact force and of the displacements, the node counts in
    /// contact, and the finite-strain solution's deepest penetration.
    fn against_linear(indent: f64, pressure_pa: f64) -> (f64, f64, usize, usize, f64) {
        let (m, mats) = artery();
        let fixed = supports(&m);
        let zeros = vec![0.0; m.dofs()];
        let force = m.lumen_pressure_forces(pressure_pa);
        let lm = LinearModel::new(&m, &mats, Analysis::PlaneStress).unwrap();
        let ind = Indenter {
            tip: Tip::Circular { radius_m: 0.008 },
            centre_x_m: 0.02,
            indent_m: indent,
            surface_y_m: 0.02,
        };
        let lin = solve_contact(&lm, &fixed, &zeros, &force, &ind).unwrap();
        let fm = FiniteModel::new(&m, &mats, Analysis::PlaneStress).unwrap();
        let f = finger();
        let mut u = zeros.clone();
        fm.advance_with_finger(
            &mut u,
            &fixed,
            (&zeros, &zeros),
            (&zeros, &force),
            Some((&f, 0.0, indent)),
            2,
        )
        .unwrap();
        let (fs, deepest) = f.forces(&m, &u, indent);
        let total_lin: f64 = lin.force_n_per_m.iter().sum();
        let total_fin: f64 = fs.iter().sum();
        assert!(total_lin > 0.0);
        let scale = lin.u.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let diff = u
            .iter()
            .zip(&lin.u)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        (
            (total_fin - total_lin).abs() / total_lin,
            diff / scale,
            fs.iter().filter(|v| **v > 0.0).count(),
            lin.active.iter().filter(|a| **a).count(),
            deepest,
        )
    }

    #[test]
    fn small_indentations_tend_to_the_linear_active_set() {
        // Indentation and pressure scaled down together by 3: the finite-strain answer
        // approaches the linear one about in proportion (the difference is geometric).
        let big = against_linear(3e-4, 300.0);
        let small = against_linear(1e-4, 100.0);
        for (r, indent) in [(big, 3e-4), (small, 1e-4)] {
            assert!(r.0 < 0.02 && r.1 < 0.03, "{r:?}");
            assert!(r.2.abs_diff(r.3) <= 2 && r.3 >= 1, "{r:?}");
            assert!(r.4 < 1e-3 * indent, "penetration {r:?}");
        }
        assert!(big.3 >= 3, "{big:?}");
        assert!(small.0 < 0.6 * big.0, "force: {small:?} vs {big:?}");
        assert!(small.1 < 0.6 * big.1, "displacement: {small:?} vs {big:?}");
    }

    #[test]
    fn finite_strain_contact_closes_with_indentation_and_opens_on_retraction() {
        let (m, mats) = artery();
        let fixed = supports(&m);
        let zeros = vec![0.0; m.dofs()];
        let force = m.lumen_pressure_forces(16e3);
        let fm = FiniteModel::new(&m, &mats, Analysis::PlaneStress).unwrap();
        let f = finger();
        let mut u = zeros.clone();
        let mut from = (0.0, zeros.clone());
        let mut widths = Vec::new();
        let mut totals = Vec::new();
        for indent in [0.001, 0.002, 0.003] {
            fm.advance_with_finger(
                &mut u,
                &fixed,
                (&zeros, &from.1),
                (&zeros, &force),
                Some((&f, from.0, indent)),
                4,
            )
            .unwrap();
            from = (indent, force.clone());
            let (fs, deepest) = f.forces(&m, &u, indent);
            assert!(deepest < 1e-3 * indent, "penetration {deepest} at {indent}");
            // Contact width in the deformed configuration.
            let xs: Vec<f64> = m
                .top
                .iter()
                .zip(&fs)
                .filter(|(_, v)| **v > 0.0)
                .map(|(&n, _)| m.nodes[n as usize][0] + u[2 * n as usize])
                .collect();
            let w = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - xs.iter().cloned().fold(f64::INFINITY, f64::min);
            assert!(
                w < 2.0 * 0.008 * 0.95,
                "contact reaches the tip's edge: {w}"
            );
            widths.push((fs.iter().filter(|v| **v > 0.0).count(), w));
            totals.push(fs.iter().sum::<f64>());
            // Every top node under the tip is on or below it (to the penalty's tolerance).
            for &n in &m.top {
                let n = n as usize;
                let x = m.nodes[n][0] + u[2 * n] - 0.02;
                if let Some([p, _, _]) = tip_surface(&f.tip, x) {
                    let y = m.nodes[n][1] + u[2 * n + 1];
                    assert!(y <= 0.02 - indent + p + 1e-3 * indent);
                }
            }
        }
        // Nodes in contact (the top spacing is 1.3 mm here, so the count moves in steps).
        assert!(
            widths[0].0 <= widths[1].0 && widths[1].0 < widths[2].0 && widths[0].0 >= 3,
            "{widths:?}"
        );
        assert!(totals[0] < totals[1] && totals[1] < totals[2], "{totals:?}");
        // Retract above the surface: the contact opens completely and the solution is the
        // pressurized block alone.
        fm.advance_with_finger(
            &mut u,
            &fixed,
            (&zeros, &force),
            (&zeros, &force),
            Some((&f, 0.003, -0.0005)),
            4,
        )
        .unwrap();
        let (fs, _) = f.forces(&m, &u, -0.0005);
        assert!(fs.iter().all(|v| *v == 0.0));
        let mut free = zeros.clone();
        fm.advance(&mut free, &fixed, (&zeros, &zeros), (&zeros, &force), 2)
            .unwrap();
        let scale = free.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let diff = u
            .iter()
            .zip(&free)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(diff < 1e-6 * scale, "{diff} of {scale}");
    }
}
