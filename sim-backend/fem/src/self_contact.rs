//! Frictionless self-contact of the lumen's wall, so that a lumen can close: a penalty on
//! node-to-segment gaps between the wall's nodes and the wall's opposite segments, in the
//! deformed configuration, both ways round (every wall node is a slave).
//!
//! For a slave node s and a facing segment a → b (lumen on its left, unit normal n̂ into the
//! lumen, tangent t), ξ = (x_s − x_a)·t/|t|² and the gap is g = (x_s − x_a)·n̂; where ξ is in
//! [0, 1] and g < 0 the energy ε/2 g² pushes s back into the lumen and a, b away from it.
//! Its force is ε g ∇g with ∇g = (n̂, −(1 − ξ) n̂, −ξ n̂) on (s, a, b), normal to the
//! segment: frictionless. The tangent kept is ε ∇g ∇gᵀ; the exact one adds ε g ∇²g, which
//! is (contact force)/(segment length) against ε, i.e. of the order of the penetration over
//! the segment, and is left out (as the finger's curvature term is).
//!
//! Candidates are found afresh at every state (the active set follows the Newton loop):
//! segments not touching s, whose normal faces s's own wall normal (n̂ · n̂_s < 0: two walls
//! closing on each other, not a node and its neighbours on one wall), with s's projection
//! on the segment and g above −`window_m` (a node further behind a segment is on another
//! part of the wall, not in contact with it). Of these the one with the smallest |g| is the
//! node's. The coupling of s with a and b is not in the stiffness's sparse pattern (they
//! share no element), so the tangent is handed to the solver as rank-one terms
//! ([`super::low_rank`]).

use super::low_rank::RankOne;
use super::lumen_wall::LumenWall;
use super::mesh::Mesh;

/// Penalty per unit of the stiffest wall material's Young's modulus, as the finger's.
pub const SELF_PENALTY_PER_MODULUS: f64 = 1e3;

/// The lumen's self-contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfContact {
    /// ε: N/m per m of penetration per m of thickness (Pa).
    pub penalty_pa: f64,
    /// How far behind a segment a node may be and still be in contact with it, m.
    pub window_m: f64,
}

/// A wall node facing a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Facing {
    pub slave: usize,
    /// Index into the wall's edges.
    pub edge: usize,
    /// Gap (negative when penetrating), m.
    pub g: f64,
    pub xi: f64,
    /// The segment's unit normal into the lumen.
    pub n: [f64; 2],
}

impl Facing {
    /// ∇g on the DOFs of (s, a, b).
    fn gradient(&self, wall: &LumenWall) -> [(usize, f64); 6] {
        let e = wall.edges[self.edge];
        let (s, a, b) = (self.slave, e.a, e.b);
        let [nx, ny] = self.n;
        let (wa, wb) = (-(1.0 - self.xi), -self.xi);
        [
            (2 * s, nx),
            (2 * s + 1, ny),
            (2 * a, wa * nx),
            (2 * a + 1, wa * ny),
            (2 * b, wb * nx),
            (2 * b + 1, wb * ny),
        ]
    }
}

/// Left unit normal (into the lumen) of the segment p → q, and its length squared.
fn left_normal(p: [f64; 2], q: [f64; 2]) -> Option<([f64; 2], [f64; 2], f64)> {
    let t = [q[0] - p[0], q[1] - p[1]];
    let l2 = t[0] * t[0] + t[1] * t[1];
    if !(l2 > 0.0 && l2.is_finite()) {
        return None;
    }
    let l = l2.sqrt();
    Some(([-t[1] / l, t[0] / l], t, l2))
}

impl SelfContact {
    /// A penalty `penalty_pa` (e.g. [`SELF_PENALTY_PER_MODULUS`] × the wall's modulus) and
    /// a window of the wall's longest reference edge.
    pub fn for_wall(wall: &LumenWall, mesh: &Mesh, penalty_pa: f64) -> Self {
        let zero = vec![0.0; mesh.dofs()];
        let longest = wall.edges.iter().fold(0.0f64, |m, e| {
            let (p, q) = (
                LumenWall::at(mesh, &zero, e.a),
                LumenWall::at(mesh, &zero, e.b),
            );
            m.max(((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt())
        });
        Self {
            penalty_pa,
            window_m: longest,
        }
    }

    /// Each wall node's facing segment at `u`, if it has one (either sign of gap).
    pub fn facings(&self, wall: &LumenWall, mesh: &Mesh, u: &[f64]) -> Vec<Facing> {
        let x: Vec<[f64; 2]> = wall
            .nodes
            .iter()
            .map(|&n| LumenWall::at(mesh, u, n))
            .collect();
        let slot = |n: usize| wall.nodes.partition_point(|&m| m < n);
        let normals: Vec<Option<([f64; 2], [f64; 2], f64)>> = wall
            .edges
            .iter()
            .map(|e| left_normal(x[slot(e.a)], x[slot(e.b)]))
            .collect();
        let mut out = Vec::new();
        for (i, &s) in wall.nodes.iter().enumerate() {
            // The node's own wall normal: the mean of its edges' normals.
            let mut ns = [0.0, 0.0];
            for k in [wall.arriving[i], wall.leaving[i]] {
                if let Some(Some((n, _, _))) = normals.get(k) {
                    ns = [ns[0] + n[0], ns[1] + n[1]];
                }
            }
            let mut best: Option<Facing> = None;
            for (k, e) in wall.edges.iter().enumerate() {
                if e.a == s || e.b == s {
                    continue;
                }
                let Some((n, t, l2)) = normals[k] else {
                    continue;
                };
                if n[0] * ns[0] + n[1] * ns[1] >= 0.0 {
                    continue;
                }
                let pa = x[slot(e.a)];
                let d = [x[i][0] - pa[0], x[i][1] - pa[1]];
                let xi = (d[0] * t[0] + d[1] * t[1]) / l2;
                let g = d[0] * n[0] + d[1] * n[1];
                if !(0.0..=1.0).contains(&xi) || g < -self.window_m {
                    continue;
                }
                if best.is_none_or(|b| g.abs() < b.g.abs()) {
                    best = Some(Facing {
                        slave: s,
                        edge: k,
                        g,
                        xi,
                        n,
                    });
                }
            }
            out.extend(best);
        }
        out
    }

    /// Add the penalty of the penetrating nodes at `u` to `fint`, and its tangent as
    /// rank-one terms to `terms`.
    pub fn add(
        &self,
        wall: &LumenWall,
        mesh: &Mesh,
        u: &[f64],
        fint: &mut [f64],
        terms: &mut Vec<RankOne>,
    ) {
        let facing = self.facings(wall, mesh, u);
        self.add_branch(wall, facing.iter().filter(|f| f.g < 0.0), fint, terms);
    }

    /// The penalty branch (force ε g ∇g, tangent ε ∇g ∇gᵀ) of the given facings.
    pub fn add_branch<'a>(
        &self,
        wall: &LumenWall,
        facings: impl Iterator<Item = &'a Facing>,
        fint: &mut [f64],
        terms: &mut Vec<RankOne>,
    ) {
        for f in facings {
            let grad = f.gradient(wall);
            for &(dof, v) in &grad {
                fint[dof] += self.penalty_pa * f.g * v;
            }
            terms.push(RankOne {
                weight: self.penalty_pa,
                entries: grad.to_vec(),
            });
        }
    }

    /// Facings open at `u` whose gap, linearized at `u`, the step `du` would close: a
    /// Newton step that ignores them would throw the walls through each other.
    pub fn closing(&self, wall: &LumenWall, mesh: &Mesh, u: &[f64], du: &[f64]) -> Vec<Facing> {
        self.facings(wall, mesh, u)
            .into_iter()
            .filter(|f| {
                let dg: f64 = f.gradient(wall).iter().map(|&(d, v)| v * du[d]).sum();
                f.g >= 0.0 && f.g + dg < 0.0
            })
            .collect()
    }

    /// Contact forces on the nodes at `u` (what the walls push each other with; the
    /// negative of the penalty's share of the internal forces), and the deepest
    /// penetration, m.
    pub fn forces(&self, wall: &LumenWall, mesh: &Mesh, u: &[f64]) -> (Vec<f64>, f64) {
        let mut f = vec![0.0; mesh.dofs()];
        let mut terms = Vec::new();
        self.add(wall, mesh, u, &mut f, &mut terms);
        for v in &mut f {
            *v = -*v;
        }
        let deepest = self
            .facings(wall, mesh, u)
            .iter()
            .fold(0.0f64, |d, fa| d.max(-fa.g));
        (f, deepest)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::finite::{FiniteModel, LumenModel};
    use crate::material::{Analysis, Material};

    const E_PA: f64 = 50e3;
    const W: f64 = 0.01;
    const H: f64 = 0.004;
    const GAP: f64 = 0.0005;

    /// An nx x ny grid of elements over [x0, x0 + w] x [y0, y0 + h]: its bottom and top rows
    /// of nodes.
    fn slab(m: &mut Mesh, y0: f64, nx: usize, ny: usize) -> (Vec<u32>, Vec<u32>) {
        let base = m.nodes.len();
        let id = |i: usize, j: usize| (base + j * (nx + 1) + i) as u32;
        for j in 0..=ny {
            for i in 0..=nx {
                m.nodes
                    .push([W * i as f64 / nx as f64, y0 + H * j as f64 / ny as f64]);
            }
        }
        for j in 0..ny {
            for i in 0..nx {
                m.elements
                    .push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                m.region.push(0);
            }
        }
        (
            (0..=nx).map(|i| id(i, 0)).collect(),
            (0..=nx).map(|i| id(i, ny)).collect(),
        )
    }

    /// Two blocks, one above the other across a gap, with non-matching nodes on the faces
    /// that meet; the two faces are the "lumen's wall".
    struct Blocks {
        mesh: Mesh,
        lower: Vec<bool>,
        fixed: Vec<bool>,
        top: Vec<u32>,
        bottom: Vec<u32>,
    }

    fn blocks() -> Blocks {
        let mut mesh = Mesh::default();
        let (bottom, lower_top) = slab(&mut mesh, 0.0, 8, 3);
        let n_lower = mesh.nodes.len();
        let (upper_bottom, top) = slab(&mut mesh, H + GAP, 7, 3);
        for row in [&lower_top, &upper_bottom] {
            mesh.lumen_edges
                .extend(row.windows(2).map(|p| [p[0], p[1]]));
        }
        mesh.top = top.clone();
        mesh.bottom = bottom.clone();
        let mut fixed = vec![false; mesh.dofs()];
        for &n in bottom.iter().chain(&top) {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * bottom[0] as usize] = true;
        fixed[2 * top[0] as usize] = true;
        let lower = (0..mesh.nodes.len()).map(|n| n < n_lower).collect();
        Blocks {
            mesh,
            lower,
            fixed,
            top,
            bottom,
        }
    }

    struct Pressed {
        /// Contact force on the upper block and on the lower block (y, N/m).
        on_upper: f64,
        on_lower: f64,
        /// Support reactions at the top and at the bottom (y, N/m).
        top_reaction: f64,
        bottom_reaction: f64,
        penetration: f64,
        active: usize,
    }

    /// Press the upper block's top down by each of `depths` in turn, with the penalty
    /// `per_modulus` × E.
    fn press(depths: &[f64], per_modulus: f64) -> Vec<Pressed> {
        let b = blocks();
        let m = &b.mesh;
        let how = LumenModel {
            follower: false,
            self_contact: true,
            penalty_per_modulus: per_modulus,
        };
        let fm = FiniteModel::new(m, &[Material::new(E_PA, 0.3)], Analysis::PlaneStrain)
            .unwrap()
            .with_lumen(how)
            .unwrap();
        let wall = LumenWall::new(m).unwrap();
        let contact = SelfContact::for_wall(&wall, m, per_modulus * E_PA);
        let zeros = vec![0.0; m.dofs()];
        let mut u = zeros.clone();
        let mut from = zeros.clone();
        let mut out = Vec::new();
        for &d in depths {
            let mut target = zeros.clone();
            for &n in &b.top {
                target[2 * n as usize + 1] = -d;
            }
            fm.advance(&mut u, &b.fixed, (&from, &zeros), (&target, &zeros), 4)
                .unwrap();
            from = target;
            let (f, penetration) = contact.forces(&wall, m, &u);
            let fint = fm.internal_forces(&u).unwrap();
            let sum_y = |nodes: &mut dyn Iterator<Item = usize>, v: &[f64]| -> f64 {
                nodes.map(|n| v[2 * n + 1]).sum()
            };
            let n_all = m.nodes.len();
            out.push(Pressed {
                on_upper: sum_y(&mut (0..n_all).filter(|&n| !b.lower[n]), &f),
                on_lower: sum_y(&mut (0..n_all).filter(|&n| b.lower[n]), &f),
                top_reaction: sum_y(&mut b.top.iter().map(|&n| n as usize), &fint),
                bottom_reaction: sum_y(&mut b.bottom.iter().map(|&n| n as usize), &fint),
                penetration,
                active: contact
                    .facings(&wall, m, &u)
                    .iter()
                    .filter(|f| f.g < 0.0)
                    .count(),
            });
        }
        out
    }

    #[test]
    fn no_contact_force_while_the_gap_is_open() {
        // Halfway across the gap, then further, then back: nothing touches.
        for p in press(&[0.5 * GAP, 0.9 * GAP, 0.3 * GAP], SELF_PENALTY_PER_MODULUS) {
            assert_eq!(p.active, 0);
            assert!(p.on_upper == 0.0 && p.on_lower == 0.0);
            assert!(p.penetration == 0.0);
            // The upper block just moves down: no load anywhere.
            assert!(p.top_reaction.abs() < 1e-9 && p.bottom_reaction.abs() < 1e-9);
        }
    }

    #[test]
    fn pressed_walls_carry_the_load_without_passing_through_each_other() {
        let squeeze = 0.0004; // 5 % of the two blocks' height
        let depths = [GAP + 0.5 * squeeze, GAP + squeeze, 0.5 * GAP];
        let soft = press(&depths, SELF_PENALTY_PER_MODULUS);
        let stiff = press(&depths, 10.0 * SELF_PENALTY_PER_MODULUS);
        for run in [&soft, &stiff] {
            for p in &run[..2] {
                assert!(p.active >= 8, "{}", p.active);
                // The contact force balances the supports on each block, and the walls
                // push each other equally.
                let scale = p.on_upper.abs();
                assert!(p.on_upper > 0.0);
                assert!((p.on_upper + p.top_reaction).abs() < 1e-6 * scale);
                assert!((p.on_lower + p.bottom_reaction).abs() < 1e-6 * scale);
                assert!((p.on_upper + p.on_lower).abs() < 1e-9 * scale);
            }
            // Uniaxial plane-strain compression of the 8 mm stack: E/(1 - ν²) ε W, within
            // the finite-strain difference.
            let want = E_PA / (1.0 - 0.09) * squeeze / (2.0 * H) * W;
            let got = run[1].on_upper;
            assert!((got - want).abs() < 0.06 * want, "{got} vs {want}");
            // Backed off to half the gap: open again, no force.
            assert!(run[2].active == 0 && run[2].on_upper == 0.0);
        }
        // Penetration is small and shrinks with the penalty (about as 1/ε).
        for (s, t) in soft.iter().zip(&stiff).take(2) {
            assert!(
                s.penetration > 0.0 && s.penetration < 1e-3 * squeeze,
                "{}",
                s.penetration
            );
            assert!(
                t.penetration < 0.15 * s.penetration,
                "{} vs {}",
                t.penetration,
                s.penetration
            );
        }
    }
}
