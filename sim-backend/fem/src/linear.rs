//! Small-strain linear elasticity on a mesh: element geometry, assembly, constrained solves
//! and stress recovery.

use std::time::Instant;

use rayon::prelude::*;

use super::element::Q4;
use super::material::{Analysis, Material};
use super::mesh::Mesh;
use super::recovery::top_stresses;
use super::solve_error::SolveError;
use super::sparse::{Constrained, Ordering, Pattern, element_dofs};

/// Wall-clock seconds spent in each phase (for the benchmark, never for tests). Assembly and
/// the symbolic analysis run side by side, so their sum exceeds the time they take together.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Timings {
    pub pattern_s: f64,
    pub assembly_s: f64,
    pub symbolic_s: f64,
}

/// An assembled linear model, ready to be factored for any set of prescribed DOFs.
#[derive(Debug)]
pub struct LinearModel<'m> {
    pub mesh: &'m Mesh,
    pub materials: Vec<Material>,
    pub analysis: Analysis,
    pub pattern: Pattern,
    pub symbolic: super::sparse::Symbolic,
    pub values: Vec<f64>,
    pub timings: Timings,
}

impl<'m> LinearModel<'m> {
    /// Assemble K. `materials[region]` gives each element's material.
    pub fn new(
        mesh: &'m Mesh,
        materials: &[Material],
        analysis: Analysis,
    ) -> Result<Self, SolveError> {
        Self::with_ordering(mesh, materials, analysis, Ordering::default())
    }

    /// As [`LinearModel::new`] with a chosen fill-reducing ordering (for the benchmark).
    pub fn with_ordering(
        mesh: &'m Mesh,
        materials: &[Material],
        analysis: Analysis,
        ordering: Ordering,
    ) -> Result<Self, SolveError> {
        let t0 = Instant::now();
        let pattern = Pattern::new(mesh)?;
        let t1 = Instant::now();
        // The ordering and symbolic analysis need only the pattern, the element matrices only
        // the mesh: on two cores the (sequential) ordering runs beside the assembly.
        let (assembled, symbolic) = rayon::join(
            || {
                let t = Instant::now();
                assemble(mesh, materials, analysis, &pattern).map(|v| (v, t.elapsed()))
            },
            || {
                let t = Instant::now();
                pattern.symbolic_with(ordering).map(|s| (s, t.elapsed()))
            },
        );
        let (values, assembly) = assembled?;
        let (symbolic, symbolic_time) = symbolic?;
        Ok(Self {
            mesh,
            materials: materials.to_vec(),
            analysis,
            pattern,
            symbolic,
            values,
            timings: Timings {
                pattern_s: (t1 - t0).as_secs_f64(),
                assembly_s: assembly.as_secs_f64(),
                symbolic_s: symbolic_time.as_secs_f64(),
            },
        })
    }

    /// Factor with the flagged DOFs prescribed.
    pub fn factor(&self, fixed: &[bool]) -> Result<Constrained<'_>, SolveError> {
        Constrained::new(&self.pattern, &self.symbolic, &self.values, fixed)
    }

    /// Gauss-point stresses of element `e`.
    pub fn gauss_stresses(&self, e: usize, u: &[f64]) -> [[f64; 4]; 4] {
        let d = element_dofs(&self.mesh.elements[e]);
        let mut ue = [0.0; 8];
        for (i, &k) in d.iter().enumerate() {
            ue[i] = u[k];
        }
        let m = &self.materials[self.mesh.region[e] as usize];
        // Elements were checked when K was assembled.
        match Q4::new(&self.mesh.element_coords(e)) {
            Ok(q) => q.stresses(m, self.analysis, &ue),
            Err(_) => [[f64::NAN; 4]; 4],
        }
    }

    /// Recovered stresses at the top nodes.
    pub fn top_stresses(&self, u: &[f64]) -> Vec<[f64; 4]> {
        top_stresses(self.mesh, |e| self.gauss_stresses(e, u))
    }
}

/// Element matrices straight from the coordinates (keeping per-element geometry for a
/// 300k-DOF mesh would cost 140 MB of memory traffic for nothing), scattered into K.
fn assemble(
    mesh: &Mesh,
    materials: &[Material],
    analysis: Analysis,
    pattern: &Pattern,
) -> Result<Vec<f64>, SolveError> {
    let ke: Vec<[f64; 36]> = (0..mesh.elements.len())
        .into_par_iter()
        .map(|e| {
            let q = Q4::new(&mesh.element_coords(e)).map_err(|_| SolveError::BadElement(e))?;
            Ok(q.stiffness_upper(&materials[mesh.region[e] as usize], analysis))
        })
        .collect::<Result<_, SolveError>>()?;
    Ok(pattern.assemble(&ke))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesher::test_artery_block;

    /// Distorted 2x2-element-per-side patch with interior nodes moved off the grid.
    fn patch() -> Mesh {
        let mut m = Mesh::default();
        let coords = [
            [0.0, 0.0],
            [0.5, 0.0],
            [1.0, 0.0],
            [0.0, 0.4],
            [0.62, 0.57],
            [1.0, 0.5],
            [0.0, 1.0],
            [0.45, 1.0],
            [1.0, 1.0],
        ];
        m.nodes = coords.to_vec();
        m.elements = vec![[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]];
        m.region = vec![0; 4];
        m.top = vec![6, 7, 8];
        m
    }

    #[test]
    fn patch_test_reproduces_constant_strain_exactly() {
        let m = patch();
        // u = (a + b x + c y, d + e x + f y): constant strain.
        let field = |p: [f64; 2]| {
            [
                1e-3 + 2e-3 * p[0] - 1e-3 * p[1],
                -2e-3 + 0.5e-3 * p[0] + 3e-3 * p[1],
            ]
        };
        let (exx, eyy, gxy) = (2e-3, 3e-3, -1e-3 + 0.5e-3);
        for analysis in [Analysis::PlaneStress, Analysis::PlaneStrain] {
            for nu in [0.3, 0.4999] {
                let mat = Material::new(1e4, nu);
                let lm = LinearModel::new(&m, &[mat], analysis).unwrap();
                let boundary = [0usize, 1, 2, 3, 5, 6, 7, 8];
                let mut fixed = vec![false; m.dofs()];
                let mut pres = vec![0.0; m.dofs()];
                for &n in &boundary {
                    let u = field(m.nodes[n]);
                    fixed[2 * n] = true;
                    fixed[2 * n + 1] = true;
                    pres[2 * n] = u[0];
                    pres[2 * n + 1] = u[1];
                }
                let c = lm.factor(&fixed).unwrap();
                let u = c.solve(&vec![0.0; m.dofs()], &pres).unwrap();
                let exact = field(m.nodes[4]);
                assert!((u[8] - exact[0]).abs() < 1e-12, "{} vs {}", u[8], exact[0]);
                assert!((u[9] - exact[1]).abs() < 1e-12);
                let l = mat.lambda_2d_pa(analysis);
                let mu = mat.mu_pa();
                let sxx = l * (exx + eyy) + 2.0 * mu * exx;
                for e in 0..4 {
                    for s in lm.gauss_stresses(e, &u) {
                        assert!((s[0] - sxx).abs() < 1e-9 * sxx.abs().max(1.0), "{s:?}");
                        assert!((s[2] - mu * gxy).abs() < 1e-9 * mu);
                    }
                }
            }
        }
    }

    /// Lamé: radial displacement of a thick cylinder under internal pressure p.
    fn lame_ur(a: f64, b: f64, p: f64, m: &Material, analysis: Analysis, r: f64) -> f64 {
        // Plane strain: u = A r + B / r with the plane-strain constants; plane stress uses
        // the in-plane Lamé λ₂.
        let mu = m.mu_pa();
        let l = m.lambda_2d_pa(analysis);
        // σrr = 2(λ+μ) A - 2μ B / r², zero at b, -p at a.
        let bb = p * a * a * b * b / (2.0 * mu * (b * b - a * a));
        let aa = p * a * a / ((b * b - a * a) * 2.0 * (l + mu));
        aa * r + bb / r
    }

    fn lame_error(n: usize, nu: f64, analysis: Analysis) -> f64 {
        let (a, b, p) = (1.0, 2.0, 1.0);
        let m = Mesh::quarter_annulus(a, b, n, 2 * n);
        let mat = Material::new(1000.0, nu);
        let lm = LinearModel::new(&m, &[mat], analysis).unwrap();
        let mut fixed = vec![false; m.dofs()];
        for (i, x) in m.nodes.iter().enumerate() {
            if x[1].abs() < 1e-12 {
                fixed[2 * i + 1] = true;
            }
            if x[0].abs() < 1e-12 {
                fixed[2 * i] = true;
            }
        }
        let f = m.lumen_pressure_forces(p);
        let c = lm.factor(&fixed).unwrap();
        let u = c.solve(&f, &vec![0.0; m.dofs()]).unwrap();
        // Root-mean-square relative error of u_r over all nodes.
        let mut num = 0.0;
        let mut den = 0.0;
        for (i, x) in m.nodes.iter().enumerate() {
            let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
            let ur = (u[2 * i] * x[0] + u[2 * i + 1] * x[1]) / r;
            let ex = lame_ur(a, b, p, &mat, analysis, r);
            num += (ur - ex).powi(2);
            den += ex * ex;
        }
        (num / den).sqrt()
    }

    #[test]
    fn thick_cylinder_converges_at_order_two() {
        for (nu, analysis) in [
            (0.3, Analysis::PlaneStress),
            (0.3, Analysis::PlaneStrain),
            (0.4999, Analysis::PlaneStrain),
        ] {
            let e: Vec<f64> = [4, 8, 16]
                .iter()
                .map(|&n| lame_error(n, nu, analysis))
                .collect();
            let rate1 = (e[0] / e[1]).log2();
            let rate2 = (e[1] / e[2]).log2();
            assert!(e[2] < 5e-3, "{analysis:?} nu {nu}: error {e:?}");
            assert!(
                rate2 > 1.8 && rate2 < 2.3,
                "{analysis:?} nu {nu}: rates {rate1} {rate2} errors {e:?}"
            );
        }
    }

    /// Plane-strain artery under a platen: the top peak must not drift as ν -> 0.5.
    fn plane_strain_peak(nu: f64) -> f64 {
        let m = test_artery_block(0.008, 0.0025, 0.0006, 0.002);
        let mats = [Material::new(15e3, nu), Material::new(300e3, nu)];
        let lm = LinearModel::new(&m, &mats, Analysis::PlaneStrain).unwrap();
        let mut fixed = vec![false; m.dofs()];
        let mut pres = vec![0.0; m.dofs()];
        for &n in &m.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * m.bottom[m.bottom.len() / 2] as usize] = true;
        for &n in &m.top {
            fixed[2 * n as usize + 1] = true;
            pres[2 * n as usize + 1] = -0.001;
        }
        let force = m.lumen_pressure_forces(13e3);
        let c = lm.factor(&fixed).unwrap();
        let u = c.solve(&force, &pres).unwrap();
        let vm = crate::recovery::von_mises_of(&lm.top_stresses(&u));
        vm.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    #[test]
    fn plane_strain_does_not_lock_as_nu_approaches_one_half() {
        let peaks: Vec<f64> = [0.45, 0.49, 0.499, 0.4999]
            .iter()
            .map(|&nu| plane_strain_peak(nu))
            .collect();
        for p in &peaks {
            assert!(p.is_finite() && *p > 0.0);
        }
        let drift = (peaks[3] - peaks[1]).abs() / peaks[1];
        assert!(drift < 0.01, "peaks {peaks:?}: drift {drift}");
    }
}
