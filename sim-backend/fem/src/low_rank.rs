//! Solves with the stiffness plus a few rank-one terms, by the Woodbury identity on K's
//! Cholesky factor.
//!
//! The lumen's self-contact couples wall nodes across the lumen that share no element, so
//! their entries are not in the sparse pattern, and adding them would change the pattern
//! (and its symbolic factorization, computed once per mesh) whenever the active set does.
//! The contact's tangent is a sum of m rank-one terms w g gᵀ (m = the nodes in contact, a
//! few dozen), so (K + G W Gᵀ)⁻¹ r = y − Z (W⁻¹ + Gᵀ Z)⁻¹ Gᵀ y with y = K⁻¹ r and
//! Z = K⁻¹ G: m more right-hand sides on the same factor and an m x m dense Cholesky.

use faer::{Mat, Side};

use super::solve_error::SolveError;
use super::sparse::Constrained;

/// The term `weight` g gᵀ, g given by its non-zero entries (DOF, value).
#[derive(Debug, Clone, PartialEq)]
pub struct RankOne {
    pub weight: f64,
    pub entries: Vec<(usize, f64)>,
}

/// Columns of Z = K⁻¹ G solved at a time (bounds the memory at this many vectors).
const CHUNK: usize = 32;

/// Solve (K + Σ w g gᵀ) u = `force` with u = `prescribed` on the `fixed` DOFs, K factored
/// with those DOFs prescribed in `k`.
pub fn solve(
    k: &Constrained<'_>,
    fixed: &[bool],
    force: &[f64],
    prescribed: &[f64],
    terms: &[RankOne],
) -> Result<Vec<f64>, SolveError> {
    if terms.is_empty() {
        return k.solve(force, prescribed);
    }
    let n = force.len();
    // A term's entries on prescribed DOFs are known: move them to the right-hand side.
    let mut rhs = force.to_vec();
    let free: Vec<Vec<(usize, f64)>> = terms
        .iter()
        .map(|t| {
            let known: f64 = t
                .entries
                .iter()
                .filter(|(d, _)| fixed[*d])
                .map(|&(d, v)| v * prescribed[d])
                .sum();
            for &(d, v) in &t.entries {
                if !fixed[d] {
                    rhs[d] -= t.weight * v * known;
                }
            }
            t.entries
                .iter()
                .copied()
                .filter(|(d, _)| !fixed[*d])
                .collect()
        })
        .collect();
    let y = k.solve(&rhs, prescribed)?;
    let dot = |g: &[(usize, f64)], v: &[f64]| g.iter().map(|&(d, x)| x * v[d]).sum::<f64>();
    let m = terms.len();
    // S = W⁻¹ + Gᵀ K⁻¹ G, filled CHUNK columns at a time.
    let mut s = Mat::<f64>::zeros(m, m);
    let zeros = vec![0.0; n];
    for start in (0..m).step_by(CHUNK) {
        let end = (start + CHUNK).min(m);
        let cols: Vec<Vec<f64>> = (start..end)
            .map(|j| {
                let mut c = vec![0.0; n];
                for &(d, v) in &free[j] {
                    c[d] += v;
                }
                c
            })
            .collect();
        let cases: Vec<(&[f64], &[f64])> = cols
            .iter()
            .map(|c| (c.as_slice(), zeros.as_slice()))
            .collect();
        let z = k.solve_many(&cases)?;
        for (j, zj) in (start..end).zip(&z) {
            for i in 0..m {
                s[(i, j)] = dot(&free[i], zj);
            }
        }
    }
    for (i, t) in terms.iter().enumerate() {
        if !(t.weight > 0.0 && t.weight.is_finite()) {
            return Err(SolveError::NotPositiveDefinite);
        }
        s[(i, i)] += 1.0 / t.weight;
    }
    // Symmetrize the round-off before the dense Cholesky.
    for i in 0..m {
        for j in 0..i {
            let v = 0.5 * (s[(i, j)] + s[(j, i)]);
            s[(i, j)] = v;
            s[(j, i)] = v;
        }
    }
    let llt = s
        .llt(Side::Lower)
        .map_err(|_| SolveError::NotPositiveDefinite)?;
    let mut w = Mat::<f64>::from_fn(m, 1, |i, _| dot(&free[i], &y));
    faer::linalg::solvers::Solve::solve_in_place(&llt, w.as_mut());
    // u = K⁻¹ (r − G w): one more solve instead of keeping Z.
    let mut corrected = rhs;
    for (i, g) in free.iter().enumerate() {
        for &(d, v) in g {
            corrected[d] -= v * w[(i, 0)];
        }
    }
    let u = k.solve(&corrected, prescribed)?;
    if u.iter().any(|v| !v.is_finite()) {
        return Err(SolveError::NonFinite);
    }
    Ok(u)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::LinearModel;
    use crate::material::{Analysis, Material};
    use crate::mesher::test_artery_block;

    #[test]
    fn the_woodbury_solve_is_the_solve_of_the_updated_matrix() {
        // A block whose lumen's opposite nodes are tied by stiff springs (couplings outside
        // the pattern): the residual of the full system is zero.
        let m = test_artery_block(0.006, 0.0026, 0.002, 0.006);
        let lm = LinearModel::new(
            &m,
            &[Material::new(50e3, 0.45), Material::new(400e3, 0.49)],
            Analysis::PlaneStress,
        )
        .unwrap();
        let mut fixed = vec![false; m.dofs()];
        for &n in &m.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * m.bottom[0] as usize] = true;
        let mut prescribed = vec![0.0; m.dofs()];
        for &n in &m.top {
            fixed[2 * n as usize + 1] = true;
            prescribed[2 * n as usize + 1] = -1e-4;
        }
        let ring: Vec<usize> = m.lumen_edges.iter().map(|e| e[0] as usize).collect();
        let half = ring.len() / 2;
        let terms: Vec<RankOne> = (0..half)
            .map(|i| {
                let (a, b) = (ring[i], ring[i + half]);
                RankOne {
                    weight: 1e7 * (1.0 + i as f64),
                    entries: vec![(2 * a + 1, 1.0), (2 * b + 1, -1.0), (2 * a, 0.3)],
                }
            })
            .collect();
        let force = m.lumen_pressure_forces(1e4);
        let c = lm.factor(&fixed).unwrap();
        let u = solve(&c, &fixed, &force, &prescribed, &terms).unwrap();
        let mut r = lm.pattern.mul(&lm.values, &u);
        for t in &terms {
            let gu: f64 = t.entries.iter().map(|&(d, v)| v * u[d]).sum();
            for &(d, v) in &t.entries {
                r[d] += t.weight * v * gu;
            }
        }
        let scale = force.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..m.dofs() {
            if fixed[i] {
                assert!((u[i] - prescribed[i]).abs() < 1e-15);
            } else {
                assert!(
                    (r[i] - force[i]).abs() < 1e-8 * scale,
                    "dof {i}: {}",
                    r[i] - force[i]
                );
            }
        }
        // The springs did something: each tied combination gᵀu all but vanishes.
        let plain = c.solve(&force, &prescribed).unwrap();
        for t in &terms {
            let g = |u: &[f64]| t.entries.iter().map(|&(d, v)| v * u[d]).sum::<f64>().abs();
            assert!(g(&u) < 0.01 * g(&plain), "{} vs {}", g(&u), g(&plain));
        }
    }
}
