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
//! node's; if the segment across its nearer vertex faces the node too (a vertex where the
//! wall turns towards it), the two share the node's penalty half and half — else the choice
//! flips between them at the vertex's bisector, where a node pressed head-on onto a vertex
//! sits, and Newton crawls.
//!
//! The coupling of s with a and b is not in an element's pattern (they share no element):
//! the solver's pattern couples every pair of wall nodes ([`wall_pairs`]), a dense block of
//! a few hundred DOFs, so the tangent is assembled and factored whole. (Handing it to the
//! factor of the tissue alone as a low-rank update fails where the contact is what holds a
//! buckled wall up: that factor is then indefinite.)

use super::lumen_wall::LumenWall;
use super::mesh::Mesh;
use super::sparse::Pattern;

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
    /// Share of the node's penalty on this segment: 1, or 1/2 each for two segments
    /// meeting at a vertex the node faces.
    pub weight: f64,
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

/// A segment's unit normal into the lumen, its tangent and its length squared.
type Frame = ([f64; 2], [f64; 2], f64);

/// Left unit normal (into the lumen) of the segment p → q, and its length squared.
fn left_normal(p: [f64; 2], q: [f64; 2]) -> Option<Frame> {
    let t = [q[0] - p[0], q[1] - p[1]];
    let l2 = t[0] * t[0] + t[1] * t[1];
    if !(l2 > 0.0 && l2.is_finite()) {
        return None;
    }
    let l = l2.sqrt();
    Some(([-t[1] / l, t[0] / l], t, l2))
}

/// Every pair of wall nodes: the pattern entries the self-contact may need.
pub fn wall_pairs(wall: &LumenWall) -> Vec<[usize; 2]> {
    let n = &wall.nodes;
    let mut out = Vec::with_capacity(n.len() * n.len().saturating_sub(1) / 2);
    for (i, &a) in n.iter().enumerate() {
        for &b in &n[i + 1..] {
            out.push([a, b]);
        }
    }
    out
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

    /// Each wall node's facing segment at `u` (or the two at a vertex it faces, weighted a
    /// half each), if it has one; either sign of gap.
    pub fn facings(&self, wall: &LumenWall, mesh: &Mesh, u: &[f64]) -> Vec<Facing> {
        let x: Vec<[f64; 2]> = wall
            .nodes
            .iter()
            .map(|&n| LumenWall::at(mesh, u, n))
            .collect();
        let slot = |n: usize| wall.nodes.partition_point(|&m| m < n);
        let normals: Vec<Option<Frame>> = wall
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
            let facing = |k: usize| -> Option<Facing> {
                let e = wall.edges.get(k)?;
                if e.a == s || e.b == s {
                    return None;
                }
                let (n, t, l2) = normals[k]?;
                if n[0] * ns[0] + n[1] * ns[1] >= 0.0 {
                    return None;
                }
                let pa = x[slot(e.a)];
                let d = [x[i][0] - pa[0], x[i][1] - pa[1]];
                let xi = (d[0] * t[0] + d[1] * t[1]) / l2;
                let g = d[0] * n[0] + d[1] * n[1];
                ((0.0..=1.0).contains(&xi) && g >= -self.window_m).then_some(Facing {
                    slave: s,
                    edge: k,
                    g,
                    xi,
                    n,
                    weight: 1.0,
                })
            };
            let Some(best) = (0..wall.edges.len())
                .filter_map(facing)
                .min_by(|a, b| a.g.abs().total_cmp(&b.g.abs()))
            else {
                continue;
            };
            // The segment across the vertex nearest the projection: if it also faces the
            // node, the node is by a vertex where the wall turns towards it, and the
            // nearest segment would flip between the two from one iterate to the next
            // (their normals differ by the turn): share the node between them instead.
            let e = wall.edges[best.edge];
            let across = if best.xi > 0.5 {
                wall.leaving[slot(e.b)]
            } else {
                wall.arriving[slot(e.a)]
            };
            match facing(across) {
                Some(other) => out.extend([
                    Facing {
                        weight: 0.5,
                        ..best
                    },
                    Facing {
                        weight: 0.5,
                        ..other
                    },
                ]),
                None => out.push(best),
            }
        }
        out
    }

    /// Add the penalty of the penetrating nodes at `u` to `fint` and its tangent to the
    /// values of `pattern` (which must couple the wall's nodes, [`wall_pairs`]).
    pub fn add(
        &self,
        wall: &LumenWall,
        mesh: &Mesh,
        pattern: &Pattern,
        u: &[f64],
        fint: &mut [f64],
        values: &mut [f64],
    ) {
        let facing = self.facings(wall, mesh, u);
        self.add_branch(
            wall,
            pattern,
            facing.iter().filter(|f| f.g < 0.0),
            fint,
            values,
        );
    }

    /// The penalty branch (force ε g ∇g, tangent ε ∇g ∇gᵀ) of the given facings.
    pub fn add_branch<'a>(
        &self,
        wall: &LumenWall,
        pattern: &Pattern,
        facings: impl Iterator<Item = &'a Facing>,
        fint: &mut [f64],
        values: &mut [f64],
    ) {
        for f in facings {
            let grad = f.gradient(wall);
            let eps = f.weight * self.penalty_pa;
            for (i, &(p, gp)) in grad.iter().enumerate() {
                fint[p] += eps * f.g * gp;
                for &(q, gq) in &grad[i..] {
                    if let Some(slot) = pattern.slot_of(p, q) {
                        values[slot] += eps * gp * gq;
                    }
                }
            }
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
        for fa in self.facings(wall, mesh, u).iter().filter(|f| f.g < 0.0) {
            let eps = fa.weight * self.penalty_pa;
            for (p, gp) in fa.gradient(wall) {
                f[p] -= eps * fa.g * gp;
            }
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

    /// A ring (lumen radius 1.5 mm, wall 0.5 mm) pinched between its top and bottom outer
    /// nodes, each moved by each of `pinch` in turn towards the centre, then, at the last
    /// pinch, pressurized to `p_pa`. Per stage: the opening through the centre, the wall
    /// nodes in contact, the deepest penetration and the walls' total contact force.
    fn pinched_ring(how: LumenModel, pinch: &[f64], p_pa: f64) -> Vec<(f64, usize, f64, f64)> {
        use crate::finite::Loads;
        let (n_r, n_t) = (3, 64);
        let m = crate::mesh::Mesh::ring(1.5e-3, 2e-3, n_r, n_t);
        let fm = FiniteModel::new(&m, &[Material::new(400e3, 0.3)], Analysis::PlaneStrain)
            .unwrap()
            .with_lumen(how)
            .unwrap();
        let top = n_t / 4 * (n_r + 1) + n_r;
        let bottom = 3 * n_t / 4 * (n_r + 1) + n_r;
        let mut fixed = vec![false; m.dofs()];
        for n in [top, bottom] {
            fixed[2 * n] = true;
            fixed[2 * n + 1] = true;
        }
        let zeros = vec![0.0; m.dofs()];
        let mut u = zeros.clone();
        let mut from = zeros.clone();
        let mut stages: Vec<(Vec<f64>, f64)> = pinch
            .iter()
            .map(|&d| {
                let mut t = zeros.clone();
                t[2 * top + 1] = -d;
                t[2 * bottom + 1] = d;
                (t, 0.0)
            })
            .collect();
        if let Some((last, _)) = stages.last().cloned() {
            stages.push((last, p_pa));
        }
        let mut p_from = 0.0;
        let mut out = Vec::new();
        for (target, p) in &stages {
            let loads = |target, lumen_pa| Loads {
                target,
                fext: &zeros,
                indent_m: 0.0,
                lumen_pa,
            };
            fm.advance_loads(
                &mut u,
                &fixed,
                loads(&from, p_from),
                loads(target, *p),
                None,
                4,
            )
            .unwrap();
            from = target.clone();
            p_from = *p;
            let l = fm.lumen_state(&u, 1e-7).unwrap();
            out.push((
                l.opening_m.unwrap(),
                l.contact_nodes,
                l.penetration_m,
                l.contact_force_n_per_m,
            ));
        }
        out
    }

    #[test]
    fn a_pinched_ring_closes_its_lumen_and_its_pressure_pushes_the_walls_apart() {
        let pinch = [0.8e-3, 1.55e-3, 1.65e-3];
        let p = 2e3;
        let with = pinched_ring(LumenModel::default(), &pinch, p);
        // Open at first, then closed through the centre: the walls touch and stop there.
        assert!(
            with[0].0 > 0.1e-3 && with[0].1 == 0 && with[0].3 == 0.0,
            "{with:?}"
        );
        for s in &with[1..3] {
            assert!(s.1 >= 2 && s.3 > 0.0, "{with:?}");
            assert!(s.0.abs() < 1e-6 && s.2 < 1e-6, "{with:?}");
        }
        assert!(
            with[2].1 > with[1].1 && with[2].3 > 10.0 * with[1].3,
            "{with:?}"
        );
        // The lumen pressure (a follower on every wall edge, in contact or not) pushes the
        // closed walls apart: less contact force, still no crossing.
        assert!(with[3].3 < with[2].3 && with[3].2 < 1e-6, "{with:?}");
        // Without the self-contact nothing stops the walls: they pass through each other.
        let without = pinched_ring(
            LumenModel {
                self_contact: false,
                ..LumenModel::default()
            },
            &pinch,
            0.0,
        );
        assert!(without[2].0 < -0.05e-3, "{without:?}");
    }

    #[test]
    fn the_wall_pattern_holds_every_contact_entry_and_the_element_ones_where_they_were() {
        let m = crate::mesh::Mesh::ring(1.5e-3, 2e-3, 2, 24);
        let wall = LumenWall::new(&m).unwrap();
        let plain = Pattern::new(&m).unwrap();
        let with = Pattern::with_pairs(&m, &wall_pairs(&wall)).unwrap();
        // Every DOF pair of two wall nodes has a slot, and distinct pairs distinct slots.
        let mut seen = std::collections::HashSet::new();
        for &a in &wall.nodes {
            for &b in &wall.nodes {
                for (p, q) in [
                    (2 * a, 2 * b),
                    (2 * a + 1, 2 * b),
                    (2 * a, 2 * b + 1),
                    (2 * a + 1, 2 * b + 1),
                ] {
                    let s = with.slot_of(p, q).unwrap();
                    assert_eq!(s, with.slot_of(q, p).unwrap());
                    if p <= q {
                        assert!(seen.insert(s), "slot {s} twice");
                    }
                }
            }
        }
        // Without the pairs, two nodes across the lumen are not coupled.
        let (a, b) = (wall.nodes[0], wall.nodes[wall.nodes.len() / 2]);
        assert!(plain.slot_of(2 * a, 2 * b).is_none());
        // Each element's entries are where the element's slot table says, in both.
        for pat in [&plain, &with] {
            for (e, el) in m.elements.iter().enumerate() {
                let d = crate::sparse::element_dofs(el);
                let mut i = 0;
                for p in 0..8 {
                    for q in p..8 {
                        assert_eq!(pat.slot_of(d[p], d[q]), Some(pat.slots[e][i] as usize));
                        i += 1;
                    }
                }
            }
        }
        assert!(Pattern::with_pairs(&m, &[[0, m.nodes.len()]]).is_err());
    }
}
