//! The lumen pressure as a follower load in finite strain: it pushes on the *deformed* wall,
//! normal to it, so a lumen that flattens or folds is loaded where its wall now is.
//!
//! On a wall edge a → b (lumen on the left, [`LumenWall`]) with current tangent
//! t = x_b − x_a, a uniform pressure p pushes the solid with p (t_y, −t_x), half to each
//! node. Its derivative per edge is p/2 [[−R, R], [−R, R]] with R = [[0, 1], [−1, 0]]: not
//! symmetric. On a closed wall the antisymmetric remainder (−R on node a's block from the
//! edge leaving a, +R from the edge arriving at a) cancels node by node: the load is p ∇A,
//! A the enclosed area, conservative with potential −p A, and its stiffness −p ∇²A is the
//! symmetric part p/2 [[0, R], [−R, 0]] per edge. So the Cholesky solver takes the exact
//! tangent and Newton stays quadratic. (On an open wall, e.g. a quarter model, the
//! symmetric part is only an approximation of the tangent: a modified Newton.)

use super::lumen_wall::LumenWall;
use super::mesh::Mesh;

/// Nodal forces (per unit thickness) of pressure `p_pa` on the deformed wall at `u`, added
/// to `out`. At u = 0 this is [`Mesh::lumen_pressure_forces`].
pub fn add_forces(wall: &LumenWall, mesh: &Mesh, u: &[f64], p_pa: f64, out: &mut [f64]) {
    for e in &wall.edges {
        let (xa, xb) = (LumenWall::at(mesh, u, e.a), LumenWall::at(mesh, u, e.b));
        let t = [xb[0] - xa[0], xb[1] - xa[1]];
        for n in [e.a, e.b] {
            out[2 * n] += 0.5 * p_pa * t[1];
            out[2 * n + 1] -= 0.5 * p_pa * t[0];
        }
    }
}

/// Index of local DOF pair (p, q), p <= q, in an element's upper triangle of 36 values.
fn upper_index(p: usize, q: usize) -> usize {
    8 * p - p * (p.saturating_sub(1)) / 2 + q - p
}

/// Add the load stiffness −(symmetric part of ∂f/∂u) of pressure `p_pa` into the element
/// matrices (upper triangles) of the wall's elements. It does not depend on `u`.
pub fn add_tangent(wall: &LumenWall, p_pa: f64, element_k: &mut [[f64; 36]]) {
    let h = 0.5 * p_pa;
    for e in &wall.edges {
        let [la, lb] = e.local;
        let k = &mut element_k[e.element];
        // K[x_a][y_b] = −p/2, K[y_a][x_b] = +p/2.
        for (p, q, v) in [(2 * la, 2 * lb + 1, -h), (2 * la + 1, 2 * lb, h)] {
            k[upper_index(p.min(q), p.max(q))] += v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::Pattern;

    /// Deterministic pseudo-random numbers in [-1, 1] (xorshift).
    fn noise(n: usize, mut s: u64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            })
            .collect()
    }

    #[test]
    fn at_rest_the_follower_load_is_the_reference_load() {
        let m = crate::mesh::Mesh::ring(1e-3, 2e-3, 2, 24);
        let w = LumenWall::new(&m).unwrap();
        let mut f = vec![0.0; m.dofs()];
        add_forces(&w, &m, &vec![0.0; m.dofs()], 1234.0, &mut f);
        let dead = m.lumen_pressure_forces(1234.0);
        for (a, b) in f.iter().zip(&dead) {
            assert!((a - b).abs() < 1e-12 * 1234.0 * 1e-3, "{a} vs {b}");
        }
    }

    #[test]
    fn the_load_follows_the_wall_and_has_no_resultant_in_any_shape() {
        let m = crate::mesh::Mesh::ring(1e-3, 2e-3, 2, 24);
        let w = LumenWall::new(&m).unwrap();
        let p = 1e4;
        // An arbitrary deformed shape: a large distortion of every node.
        let u: Vec<f64> = noise(m.dofs(), 7).iter().map(|v| 2e-4 * v).collect();
        let x = |u: &[f64], n: usize| LumenWall::at(&m, u, n);
        let mut f = vec![0.0; m.dofs()];
        add_forces(&w, &m, &u, p, &mut f);
        let (mut fx, mut fy, mut moment, mut size) = (0.0, 0.0, 0.0, 0.0f64);
        for n in 0..m.nodes.len() {
            let xy = x(&u, n);
            fx += f[2 * n];
            fy += f[2 * n + 1];
            moment += xy[0] * f[2 * n + 1] - xy[1] * f[2 * n];
            size = size.max(f[2 * n].abs()).max(f[2 * n + 1].abs());
        }
        assert!(size > 0.0);
        assert!(
            fx.abs() < 1e-12 * size && fy.abs() < 1e-12 * size,
            "{fx} {fy}"
        );
        assert!(moment.abs() < 1e-12 * size * 2e-3, "moment {moment}");
        // Rotate that shape rigidly by 40°: every nodal force rotates with it.
        let (c, s) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
        let mut rotated = vec![0.0; m.dofs()];
        for n in 0..m.nodes.len() {
            let xy = x(&u, n);
            let r = [c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]];
            rotated[2 * n] = r[0] - m.nodes[n][0];
            rotated[2 * n + 1] = r[1] - m.nodes[n][1];
        }
        let mut fr = vec![0.0; m.dofs()];
        add_forces(&w, &m, &rotated, p, &mut fr);
        for n in 0..m.nodes.len() {
            let want = [
                c * f[2 * n] - s * f[2 * n + 1],
                s * f[2 * n] + c * f[2 * n + 1],
            ];
            assert!((fr[2 * n] - want[0]).abs() < 1e-9 * size);
            assert!((fr[2 * n + 1] - want[1]).abs() < 1e-9 * size);
        }
    }

    #[test]
    fn on_a_closed_wall_the_symmetric_tangent_is_the_exact_derivative() {
        let m = crate::mesh::Mesh::ring(1e-3, 2e-3, 1, 16);
        let w = LumenWall::new(&m).unwrap();
        assert!(w.is_closed());
        let p = 1e4;
        let pattern = Pattern::new(&m).unwrap();
        let mut ke = vec![[0.0; 36]; m.elements.len()];
        add_tangent(&w, p, &mut ke);
        let k = pattern.assemble(&ke);
        let u: Vec<f64> = noise(m.dofs(), 3).iter().map(|v| 1e-4 * v).collect();
        let h = 1e-7;
        for seed in [11, 12, 13] {
            let v = noise(m.dofs(), seed);
            let shift = |s: f64| -> Vec<f64> {
                let us: Vec<f64> = u.iter().zip(&v).map(|(a, b)| a + s * b).collect();
                let mut f = vec![0.0; m.dofs()];
                add_forces(&w, &m, &us, p, &mut f);
                f
            };
            let (fp, fm) = (shift(h), shift(-h));
            let kv = pattern.mul(&k, &v);
            let scale = kv.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            for i in 0..m.dofs() {
                // K is −∂f/∂u.
                let fd = -(fp[i] - fm[i]) / (2.0 * h);
                assert!(
                    (fd - kv[i]).abs() < 1e-6 * scale,
                    "dof {i}: {fd} vs {}",
                    kv[i]
                );
            }
        }
    }

    #[test]
    fn upper_indices_follow_the_element_layout() {
        let mut i = 0;
        for p in 0..8 {
            for q in p..8 {
                assert_eq!(upper_index(p, q), i);
                i += 1;
            }
        }
    }

    /// The ring under pressure `p_pa` with the follower or the dead load: mean radial
    /// displacement of the inner nodes, its spread, and the supports' largest reaction.
    fn pressurized_ring(p_pa: f64, follower: bool) -> (f64, f64, f64) {
        use crate::finite::{FiniteModel, Loads, LumenModel};
        use crate::material::{Analysis, Material};
        let (a, b, n_r, n_t) = (1e-3, 2e-3, 4, 48);
        let m = crate::mesh::Mesh::ring(a, b, n_r, n_t);
        let how = LumenModel {
            follower,
            self_contact: false,
            ..LumenModel::default()
        };
        let fm = FiniteModel::new(&m, &[Material::new(50e3, 0.3)], Analysis::PlaneStress)
            .unwrap()
            .with_lumen(how)
            .unwrap();
        // Rigid-body modes: inner nodes at 0° and 180° held in y, at 90° in x (by symmetry
        // they carry nothing).
        let node = |j: usize| j * (n_r + 1);
        let mut fixed = vec![false; m.dofs()];
        fixed[2 * node(0) + 1] = true;
        fixed[2 * node(n_t / 2) + 1] = true;
        fixed[2 * node(n_t / 4)] = true;
        let zeros = vec![0.0; m.dofs()];
        let mut u = zeros.clone();
        let at = |p| Loads {
            target: &zeros,
            fext: &zeros,
            indent_m: 0.0,
            lumen_pa: p,
        };
        fm.advance_loads(&mut u, &fixed, at(0.0), at(p_pa), None, 4)
            .unwrap();
        let radial: Vec<f64> = (0..n_t)
            .map(|j| {
                let n = node(j);
                let [x, y] = m.nodes[n];
                (x * u[2 * n] + y * u[2 * n + 1]) / a
            })
            .collect();
        let mean = radial.iter().sum::<f64>() / n_t as f64;
        let spread = radial.iter().fold(0.0f64, |s, r| s.max((r - mean).abs()));
        let fint = fm.internal_forces(&u).unwrap();
        let reaction = (0..m.dofs())
            .filter(|&d| fixed[d])
            .fold(0.0f64, |r, d| r.max(fint[d].abs()));
        (mean, spread, reaction)
    }

    #[test]
    fn a_pressurized_ring_expands_as_lame_says_and_a_follower_more_than_a_dead_load() {
        // Small strain (p/E = 10⁻⁴): Lamé's plane-stress thick cylinder,
        // u(a) = [(1 − ν) A a + (1 + ν) B/a]/E, A = p a²/(b² − a²), B = A b².
        let (a, b, e, nu, p) = (1e-3, 2e-3, 50e3, 0.3, 5.0);
        let big_a = p * a * a / (b * b - a * a);
        let lame = ((1.0 - nu) * big_a * a + (1.0 + nu) * big_a * b * b / a) / e;
        let (u, spread, reaction) = pressurized_ring(p, true);
        assert!((u - lame).abs() < 0.015 * lame, "{u} vs Lamé {lame}");
        assert!(spread < 1e-6 * u, "not axisymmetric: {spread} of {u}");
        assert!(reaction < 1e-6 * p * a, "supports loaded: {reaction}");
        let (dead, _, _) = pressurized_ring(p, false);
        assert!((dead - u).abs() < 1e-3 * u, "{dead} vs {u}");
        // At p/E = 0.1 the follower pushes on the enlarged wall, the dead load on the
        // reference one: the follower ring expands more, and both stay axisymmetric.
        let (fu, fs, _) = pressurized_ring(5e3, true);
        let (du, ds, _) = pressurized_ring(5e3, false);
        assert!(fs < 1e-6 * fu && ds < 1e-6 * du, "{fs} {ds}");
        assert!(fu > 1.02 * du, "follower {fu} vs dead {du}");
    }
}
