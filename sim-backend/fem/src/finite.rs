//! Finite-strain option: compressible neo-Hookean, total Lagrangian Q4, Newton-Raphson with
//! load stepping, step cut-backs and a backtracking line search.
//!
//! W = μ/2 (tr C - 3) - μ ln J + λ/2 (ln J)², which reduces to the linear law with the same
//! E and ν at small strain. S = μ (I - C⁻¹) + λ ln J C⁻¹. Plane strain has C₃₃ = 1; plane
//! stress finds C₃₃ at each Gauss point from S₃₃ = 0 (a scalar Newton solve) and condenses the
//! tangent. Lumen pressure keeps its reference direction (dead load, no follower term), as
//! the issue specifies. The rigid finger enters as a penalty on the deformed configuration
//! ([`super::finger_penalty`]), its indentation ramped with the load.
//!
//! Plane strain near ν = 0.5 would lock under full 2x2 integration, as the linear element
//! would without its B-bar. So, as there, the λ term is the mean dilatation's: per element,
//! `V λ/2 (ln θ)²` with θ = v/V its deformed over reference area (the Q1/P0 mixed element
//! with its constant pressure condensed out; Simo, Taylor and Pister 1985, Bonet and Wood
//! section 8.6), while the μ terms stay at the Gauss points. It is an energy, so the tangent
//! stays symmetric and the Cholesky solver serves; F-bar's consistent tangent is not
//! symmetric. At small strain it is exactly the linear B-bar element. Plane stress does not
//! lock (λ condenses to a bounded λ₂) and keeps the full rule.

use rayon::prelude::*;

use super::boundary::supports;
use super::contact::Indenter;
use super::element::{Q4, extrapolate_to_nodes};
use super::finger_penalty::{FingerPenalty, PENALTY_PER_MODULUS};
use super::material::{Analysis, Material};
use super::mesh::Mesh;
use super::model::{Load, ModelFile};
use super::recovery::top_stresses;
use super::solve_error::SolveError;
use super::sparse::{Constrained, Pattern, element_dofs};

/// Stress and tangent of the material at one point.
#[derive(Debug, Clone, Copy)]
pub struct PointState {
    /// Second Piola-Kirchhoff (S11, S22, S12).
    pub s: [f64; 3],
    /// Voigt tangent dS/dE (engineering shear).
    pub d: [[f64; 3]; 3],
    /// 3-D Jacobian det F (includes the thickness stretch in plane stress).
    pub j: f64,
    /// Cauchy σ33.
    pub sigma33: f64,
}

/// Neo-Hookean response to the in-plane deformation gradient `f` (row i, column J).
pub fn neo_hookean(m: &Material, analysis: Analysis, f: &[[f64; 2]; 2]) -> Option<PointState> {
    neo_hookean_lame(m.mu_pa(), m.lambda_pa(), analysis, f)
}

/// [`neo_hookean`] with the Lamé constants given (λ = 0 for the μ terms alone).
fn neo_hookean_lame(
    mu: f64,
    lam: f64,
    analysis: Analysis,
    f: &[[f64; 2]; 2],
) -> Option<PointState> {
    let c11 = f[0][0] * f[0][0] + f[1][0] * f[1][0];
    let c22 = f[0][1] * f[0][1] + f[1][1] * f[1][1];
    let c12 = f[0][0] * f[0][1] + f[1][0] * f[1][1];
    let det2 = c11 * c22 - c12 * c12;
    let fdet = f[0][0] * f[1][1] - f[0][1] * f[1][0];
    if !(det2 > 0.0 && fdet > 0.0) {
        return None;
    }
    let c33 = match analysis {
        Analysis::PlaneStrain => 1.0,
        Analysis::PlaneStress => {
            // μ (c33 - 1) + λ/2 (ln det2 + ln c33) = 0: increasing in c33, one root.
            let mut c = 1.0f64;
            let ln_d = det2.ln();
            for _ in 0..50 {
                let g = mu * (c - 1.0) + 0.5 * lam * (ln_d + c.ln());
                let dg = mu + 0.5 * lam / c;
                let step = g / dg;
                let mut next = c - step;
                if next <= 0.0 {
                    next = 0.5 * c;
                }
                let done = (next - c).abs() <= 1e-14 * c;
                c = next;
                if done {
                    break;
                }
            }
            c
        }
    };
    let ln_j = 0.5 * (det2.ln() + c33.ln());
    let j = ln_j.exp();
    let ci = [c22 / det2, c11 / det2, -c12 / det2]; // (Ci11, Ci22, Ci12)
    let s = [
        mu * (1.0 - ci[0]) + lam * ln_j * ci[0],
        mu * (1.0 - ci[1]) + lam * ln_j * ci[1],
        -mu * ci[2] + lam * ln_j * ci[2],
    ];
    // Voigt index -> (a, b).
    let ab = [(0usize, 0usize), (1, 1), (0, 1)];
    let cim = |a: usize, b: usize| -> f64 {
        match (a, b) {
            (0, 0) => ci[0],
            (1, 1) => ci[1],
            _ => ci[2],
        }
    };
    let w = 2.0 * (mu - lam * ln_j);
    let cond = match analysis {
        Analysis::PlaneStrain => 0.0,
        Analysis::PlaneStress => lam * lam / (lam + 2.0 * mu - 2.0 * lam * ln_j),
    };
    let mut d = [[0.0; 3]; 3];
    for (i, &(a, b)) in ab.iter().enumerate() {
        for (k, &(c, e)) in ab.iter().enumerate() {
            let sym = 0.5 * (cim(a, c) * cim(b, e) + cim(a, e) * cim(b, c));
            d[i][k] = (lam - cond) * cim(a, b) * cim(c, e) + w * sym;
        }
    }
    let sigma33 = match analysis {
        Analysis::PlaneStress => 0.0,
        Analysis::PlaneStrain => lam * ln_j / j,
    };
    Some(PointState { s, d, j, sigma33 })
}

/// Deformation gradient at Gauss point `g` of element geometry `q` for element
/// displacements `ue`.
fn deformation_gradient(q: &Q4, g: usize, ue: &[f64; 8]) -> [[f64; 2]; 2] {
    let b = &q.b[g];
    let mut f = [[1.0, 0.0], [0.0, 1.0]];
    for a in 0..4 {
        let (dx, dy) = (b[0][2 * a], b[1][2 * a + 1]);
        f[0][0] += ue[2 * a] * dx;
        f[0][1] += ue[2 * a] * dy;
        f[1][0] += ue[2 * a + 1] * dx;
        f[1][1] += ue[2 * a + 1] * dy;
    }
    f
}

/// Internal force (8) and tangent (upper 36) of one element; `None` if a point inverts.
fn element_state(
    q: &Q4,
    m: &Material,
    analysis: Analysis,
    ue: &[f64; 8],
) -> Option<([f64; 8], [f64; 36])> {
    let mut fint = [0.0; 8];
    let mut k = [[0.0; 8]; 8];
    let mean_dilatation = analysis == Analysis::PlaneStrain;
    let lam_point = if mean_dilatation { 0.0 } else { m.lambda_pa() };
    // ∂v/∂u (v the deformed area) and Σ w (N_a,1 N_b,2 - N_a,2 N_b,1), for the λ term.
    let mut dv = [0.0; 8];
    let mut v = 0.0;
    let mut cross = [[0.0; 4]; 4];
    for g in 0..4 {
        let f = deformation_gradient(q, g, ue);
        let st = neo_hookean_lame(m.mu_pa(), lam_point, analysis, &f)?;
        let w = q.w[g];
        let bq = &q.b[g];
        let mut bnl = [[0.0; 8]; 3];
        let mut dn = [[0.0; 2]; 4];
        if mean_dilatation {
            v += w * (f[0][0] * f[1][1] - f[0][1] * f[1][0]);
        }
        for a in 0..4 {
            let (n1, n2) = (bq[0][2 * a], bq[1][2 * a + 1]);
            dn[a] = [n1, n2];
            if mean_dilatation {
                // ∂J/∂F = cof F = [[F22, -F21], [-F12, F11]].
                dv[2 * a] += w * (f[1][1] * n1 - f[1][0] * n2);
                dv[2 * a + 1] += w * (-f[0][1] * n1 + f[0][0] * n2);
            }
            bnl[0][2 * a] = f[0][0] * n1;
            bnl[0][2 * a + 1] = f[1][0] * n1;
            bnl[1][2 * a] = f[0][1] * n2;
            bnl[1][2 * a + 1] = f[1][1] * n2;
            bnl[2][2 * a] = f[0][0] * n2 + f[0][1] * n1;
            bnl[2][2 * a + 1] = f[1][0] * n2 + f[1][1] * n1;
        }
        for p in 0..8 {
            fint[p] += w * (bnl[0][p] * st.s[0] + bnl[1][p] * st.s[1] + bnl[2][p] * st.s[2]);
        }
        // D B
        let mut db = [[0.0; 8]; 3];
        for r in 0..3 {
            for p in 0..8 {
                db[r][p] = st.d[r][0] * bnl[0][p] + st.d[r][1] * bnl[1][p] + st.d[r][2] * bnl[2][p];
            }
        }
        for p in 0..8 {
            for qq in p..8 {
                k[p][qq] +=
                    w * (bnl[0][p] * db[0][qq] + bnl[1][p] * db[1][qq] + bnl[2][p] * db[2][qq]);
            }
        }
        // Geometric stiffness ∇N_a · S · ∇N_b on both components.
        for a in 0..4 {
            for b in a..4 {
                let (x, y) = (dn[a], dn[b]);
                if mean_dilatation {
                    cross[a][b] += w * (x[0] * y[1] - x[1] * y[0]);
                    cross[b][a] -= w * (x[0] * y[1] - x[1] * y[0]);
                }
                let gab = w
                    * (x[0] * st.s[0] * y[0]
                        + x[0] * st.s[2] * y[1]
                        + x[1] * st.s[2] * y[0]
                        + x[1] * st.s[1] * y[1]);
                for c in 0..2 {
                    let (p, qq) = (2 * a + c, 2 * b + c);
                    k[p.min(qq)][p.max(qq)] += gab;
                }
            }
        }
    }
    if mean_dilatation {
        add_mean_dilatation(m.lambda_pa(), q.area, v, &dv, &cross, &mut fint, &mut k)?;
    }
    let mut up = [0.0; 36];
    let mut i = 0;
    for (p, row) in k.iter().enumerate() {
        for &v in &row[p..] {
            up[i] = v;
            i += 1;
        }
    }
    Some((fint, up))
}

/// The mean dilatation's λ term `V φ(θ)`, φ(θ) = λ/2 (ln θ)², θ = v/V: its force φ'(θ) ∂v/∂u
/// and tangent φ''(θ)/V ∂v/∂u ⊗ ∂v/∂u + φ'(θ) ∂²v/∂u², where ∂²v/∂u_ia∂u_kb = ε_ik cross[a][b]
/// (v is quadratic in u in 2-D). `None` if the element's area has inverted.
fn add_mean_dilatation(
    lam: f64,
    area: f64,
    v: f64,
    dv: &[f64; 8],
    cross: &[[f64; 4]; 4],
    fint: &mut [f64; 8],
    k: &mut [[f64; 8]; 8],
) -> Option<()> {
    let theta = v / area;
    if !(theta > 0.0 && theta.is_finite()) {
        return None;
    }
    let ln_t = theta.ln();
    let d1 = lam * ln_t / theta;
    let d2 = lam * (1.0 - ln_t) / (theta * theta);
    for p in 0..8 {
        fint[p] += d1 * dv[p];
        for q in p..8 {
            k[p][q] += d2 / area * dv[p] * dv[q];
        }
    }
    // ε_12 = 1, ε_21 = -1, ε_11 = ε_22 = 0: only (x of a, y of b) pairs.
    for a in 0..4 {
        for b in 0..4 {
            let (p, q) = (2 * a, 2 * b + 1);
            k[p.min(q)][p.max(q)] += d1 * cross[a][b];
        }
    }
    Some(())
}

/// The mean dilatation's pressure φ'(θ) = λ ln θ / θ of an element (Cauchy, added to every
/// normal component), for plane strain; 0 in plane stress.
fn mean_pressure(q: &Q4, m: &Material, analysis: Analysis, ue: &[f64; 8]) -> f64 {
    if analysis != Analysis::PlaneStrain {
        return 0.0;
    }
    let v: f64 = (0..4)
        .map(|g| {
            let f = deformation_gradient(q, g, ue);
            q.w[g] * (f[0][0] * f[1][1] - f[0][1] * f[1][0])
        })
        .sum();
    let theta = v / q.area;
    m.lambda_pa() * theta.ln() / theta
}

/// Cauchy stress (σxx, σyy, σxy, σzz) at each Gauss point of an element.
fn element_cauchy(q: &Q4, m: &Material, analysis: Analysis, ue: &[f64; 8]) -> [[f64; 4]; 4] {
    let mut out = [[f64::NAN; 4]; 4];
    let p = mean_pressure(q, m, analysis, ue);
    let lam_point = if analysis == Analysis::PlaneStrain {
        0.0
    } else {
        m.lambda_pa()
    };
    for (g, o) in out.iter_mut().enumerate() {
        let f = deformation_gradient(q, g, ue);
        if let Some(st) = neo_hookean_lame(m.mu_pa(), lam_point, analysis, &f) {
            let s = [[st.s[0], st.s[2]], [st.s[2], st.s[1]]];
            let mut fs = [[0.0; 2]; 2];
            for i in 0..2 {
                for jj in 0..2 {
                    fs[i][jj] = f[i][0] * s[0][jj] + f[i][1] * s[1][jj];
                }
            }
            let mut sig = [[0.0; 2]; 2];
            for i in 0..2 {
                for jj in 0..2 {
                    sig[i][jj] = (fs[i][0] * f[jj][0] + fs[i][1] * f[jj][1]) / st.j;
                }
            }
            *o = [sig[0][0] + p, sig[1][1] + p, sig[0][1], st.sigma33 + p];
        }
    }
    out
}

/// The nonlinear problem on one mesh.
#[derive(Debug)]
pub struct FiniteModel<'m> {
    pub mesh: &'m Mesh,
    pub materials: Vec<Material>,
    pub analysis: Analysis,
    elements: Vec<Q4>,
    pattern: Pattern,
    symbolic: super::sparse::Symbolic,
}

/// Newton settings.
const MAX_NEWTON: usize = 30;
const MAX_CUTS: u32 = 10;
const TOL_R: f64 = 1e-8;
/// Re-solves of one Newton step for nodes it would push into the finger.
const MAX_CLOSING_PASSES: usize = 6;

impl<'m> FiniteModel<'m> {
    pub fn new(
        mesh: &'m Mesh,
        materials: &[Material],
        analysis: Analysis,
    ) -> Result<Self, SolveError> {
        let pattern = Pattern::new(mesh)?;
        let elements = (0..mesh.elements.len())
            .map(|e| Q4::new(&mesh.element_coords(e)).map_err(|_| SolveError::BadElement(e)))
            .collect::<Result<Vec<_>, _>>()?;
        let symbolic = pattern.symbolic()?;
        Ok(Self {
            mesh,
            materials: materials.to_vec(),
            analysis,
            elements,
            pattern,
            symbolic,
        })
    }

    fn gather(&self, e: usize, u: &[f64]) -> [f64; 8] {
        let d = element_dofs(&self.mesh.elements[e]);
        let mut ue = [0.0; 8];
        for (i, &k) in d.iter().enumerate() {
            ue[i] = u[k];
        }
        ue
    }

    /// Internal forces and tangent values at `u` (with the finger's penalty, if any, at its
    /// indentation); `None` if any element inverts.
    fn state(&self, u: &[f64], finger: Finger<'_>) -> Option<(Vec<f64>, Vec<f64>)> {
        let per: Option<Vec<([f64; 8], [f64; 36])>> = (0..self.mesh.elements.len())
            .into_par_iter()
            .map(|e| {
                let m = &self.materials[self.mesh.region[e] as usize];
                element_state(&self.elements[e], m, self.analysis, &self.gather(e, u))
            })
            .collect();
        let per = per?;
        let mut fint = vec![0.0; self.mesh.dofs()];
        let mut ke = Vec::with_capacity(per.len());
        for (e, (f, k)) in per.into_iter().enumerate() {
            for (i, &d) in element_dofs(&self.mesh.elements[e]).iter().enumerate() {
                fint[d] += f[i];
            }
            ke.push(k);
        }
        let mut values = self.pattern.assemble(&ke);
        if let Some((f, indent_m)) = finger {
            f.add(
                self.mesh,
                &self.pattern,
                u,
                indent_m,
                &mut fint,
                &mut values,
            );
        }
        Some((fint, values))
    }

    fn residual_norm(fixed: &[bool], fext: &[f64], fint: &[f64]) -> f64 {
        fext.iter()
            .zip(fint)
            .zip(fixed)
            .filter(|(_, f)| !**f)
            .map(|((a, b), _)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    }

    /// One Newton direction. With a finger, nodes the step would push into the tip are
    /// given the penalty branch they are entering and the step is recomputed (a few times
    /// at most; the set only grows).
    #[allow(clippy::too_many_arguments)]
    fn newton_step(
        &self,
        x: &[f64],
        fint: &[f64],
        kv: &[f64],
        fixed: &[bool],
        fext: &[f64],
        du_c: &[f64],
        finger: Finger<'_>,
    ) -> Result<Vec<f64>, SolveError> {
        let solve = |fi: &[f64], k: &[f64]| -> Result<Vec<f64>, SolveError> {
            let rhs: Vec<f64> = fext.iter().zip(fi).map(|(a, b)| a - b).collect();
            Constrained::new(&self.pattern, &self.symbolic, k, fixed)?.solve(&rhs, du_c)
        };
        let mut du = solve(fint, kv)?;
        let Some((f, indent_m)) = finger else {
            return Ok(du);
        };
        let mut extra = vec![false; self.mesh.top.len()];
        for _ in 0..MAX_CLOSING_PASSES {
            let closing = f.closing(self.mesh, x, &du, indent_m);
            if closing.iter().zip(&extra).all(|(c, e)| !c || *e) {
                break;
            }
            for (e, c) in extra.iter_mut().zip(&closing) {
                *e |= *c;
            }
            let mut fi = fint.to_vec();
            let mut k = kv.to_vec();
            f.add_closing(
                self.mesh,
                &self.pattern,
                x,
                indent_m,
                &extra,
                &mut fi,
                &mut k,
            );
            du = solve(&fi, &k)?;
        }
        Ok(du)
    }

    /// Newton at one load level: prescribed `target` on fixed DOFs, external `fext`.
    /// Updates `u` in place only on success.
    fn equilibrate(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        target: &[f64],
        fext: &[f64],
        finger: Finger<'_>,
    ) -> Result<usize, SolveError> {
        let mut x = u.clone();
        let (mut fint, mut kv) = self.state(&x, finger).ok_or(SolveError::NonFinite)?;
        // Force scale: applied loads and support reactions at the current iterate.
        let scale = |fint: &[f64]| -> f64 {
            let ext: f64 = fext.iter().map(|v| v * v).sum();
            let reac: f64 = fint
                .iter()
                .zip(fixed)
                .filter(|(_, f)| **f)
                .map(|(v, _)| v * v)
                .sum();
            ext.max(reac).sqrt().max(1e-30)
        };
        for it in 0..MAX_NEWTON {
            let du_c: Vec<f64> = target.iter().zip(&x).map(|(t, xi)| t - xi).collect();
            let du = self.newton_step(&x, &fint, &kv, fixed, fext, &du_c, finger)?;
            let r0 = Self::residual_norm(fixed, fext, &fint);
            let constrained_jump = du_c.iter().zip(fixed).any(|(d, f)| *f && d.abs() > 0.0);
            // Backtracking: accept the first step that keeps every element valid and, once
            // the supports are in place, reduces the residual.
            let mut alpha = 1.0;
            let mut accepted = None;
            for _ in 0..8 {
                let trial: Vec<f64> = x.iter().zip(&du).map(|(a, d)| a + alpha * d).collect();
                if let Some((fi, k)) = self.state(&trial, finger) {
                    let r1 = Self::residual_norm(fixed, fext, &fi);
                    if constrained_jump
                        || r1 < (1.0 - 1e-4 * alpha) * r0
                        || r1 <= TOL_R * scale(&fi)
                    {
                        accepted = Some((trial, fi, k, r1));
                        break;
                    }
                }
                alpha *= 0.5;
            }
            let Some((trial, fi, k, r1)) = accepted else {
                return Err(SolveError::NoConvergence(format!(
                    "line search failed at Newton iteration {it}"
                )));
            };
            let du_norm = du.iter().map(|v| v * v).sum::<f64>().sqrt() * alpha;
            let u_norm = trial.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-30);
            x = trial;
            fint = fi;
            kv = k;
            let supports_done = target
                .iter()
                .zip(&x)
                .zip(fixed)
                .all(|((t, xi), f)| !*f || (t - xi).abs() <= 1e-12 * u_norm.max(1e-12));
            if supports_done && r1 <= TOL_R * scale(&fint) && du_norm <= 1e-6 * u_norm {
                *u = x;
                return Ok(it + 1);
            }
        }
        Err(SolveError::NoConvergence(format!(
            "Newton did not converge in {MAX_NEWTON} iterations"
        )))
    }

    /// Move from load level a to b (prescribed values and forces interpolated linearly) in
    /// `steps` increments, halving a failed increment up to `MAX_CUTS` times.
    pub fn advance(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        (target_a, fext_a): (&[f64], &[f64]),
        (target_b, fext_b): (&[f64], &[f64]),
        steps: u32,
    ) -> Result<(), SolveError> {
        self.advance_with_finger(
            u,
            fixed,
            (target_a, fext_a),
            (target_b, fext_b),
            None,
            steps,
        )
    }

    /// As [`FiniteModel::advance`], with a finger whose indentation moves from `indent.1`
    /// to `indent.2` along with the other loads.
    pub fn advance_with_finger(
        &self,
        u: &mut Vec<f64>,
        fixed: &[bool],
        (target_a, fext_a): (&[f64], &[f64]),
        (target_b, fext_b): (&[f64], &[f64]),
        finger: Option<(&FingerPenalty, f64, f64)>,
        steps: u32,
    ) -> Result<(), SolveError> {
        let lerp = |a: &[f64], b: &[f64], s: f64| -> Vec<f64> {
            a.iter().zip(b).map(|(x, y)| x + s * (y - x)).collect()
        };
        let mut s = 0.0f64;
        let mut ds = 1.0 / f64::from(steps.max(1));
        let mut cuts = 0;
        while s < 1.0 - 1e-12 {
            let next = (s + ds).min(1.0);
            let target = lerp(target_a, target_b, next);
            let fext = lerp(fext_a, fext_b, next);
            let at = finger.map(|(f, a, b)| (f, a + next * (b - a)));
            match self.equilibrate(u, fixed, &target, &fext, at) {
                Ok(_) => {
                    s = next;
                    if cuts > 0 {
                        ds *= 1.5;
                    }
                }
                Err(e) => {
                    cuts += 1;
                    if cuts > MAX_CUTS {
                        return Err(SolveError::NoConvergence(format!(
                            "load step cut {MAX_CUTS} times at load fraction {s:.4}: {e}"
                        )));
                    }
                    ds *= 0.5;
                }
            }
        }
        Ok(())
    }

    /// Recovered Cauchy stresses at the top nodes.
    pub fn top_cauchy(&self, u: &[f64]) -> Vec<[f64; 4]> {
        top_stresses(self.mesh, |e| {
            let m = &self.materials[self.mesh.region[e] as usize];
            element_cauchy(&self.elements[e], m, self.analysis, &self.gather(e, u))
        })
    }
}

/// The finger's penalty and indentation at one load level.
type Finger<'a> = Option<(&'a FingerPenalty, f64)>;

/// One output time of a finite-strain solve.
#[derive(Debug, Clone)]
pub struct TopState {
    pub t_s: f64,
    /// Recovered top Cauchy stresses (σxx, σyy, σxy, σzz) per top node.
    pub stresses: Vec<[f64; 4]>,
    pub u: Vec<f64>,
    /// The finger's deepest penetration at this time (0 without a finger), m.
    pub penetration_m: f64,
}

/// The finger of a model's load, as a penalty scaled by the tissue's modulus.
pub fn finger_of(model: &ModelFile) -> Option<(FingerPenalty, f64)> {
    match model.load {
        Load::Finger {
            tip,
            indent_m,
            centre_x_m,
        } => {
            let ind = Indenter {
                tip,
                centre_x_m: centre_x_m.unwrap_or_else(|| model.x_origin_m()),
                indent_m,
                surface_y_m: model.block.height_m,
            };
            Some((
                FingerPenalty {
                    tip: ind.tip,
                    centre_x_m: ind.centre_x_m,
                    surface_y_m: ind.surface_y_m,
                    penalty_pa: PENALTY_PER_MODULUS * model.tissue.e_pa,
                },
                indent_m,
            ))
        }
        Load::Platen { .. } => None,
    }
}

/// Solve a model in finite strain: ramp the platen or the finger and the first time's lumen
/// pressure from zero in `steps` increments, then follow the pressure through the output
/// times.
pub fn solve_times(
    model: &ModelFile,
    mesh: &Mesh,
    steps: u32,
) -> Result<Vec<TopState>, SolveError> {
    let fm = FiniteModel::new(mesh, &model.materials(), model.analysis)?;
    let (fixed, target) = supports(mesh, model);
    let finger = finger_of(model);
    let unit = mesh.lumen_pressure_forces(1.0);
    let zeros = vec![0.0; mesh.dofs()];
    let mut u = zeros.clone();
    let mut out = Vec::new();
    let mut prev: Option<Vec<f64>> = None;
    for &t in &model.times_s {
        let p = model.pressure_at(t);
        let fext: Vec<f64> = unit.iter().map(|f| f * p).collect();
        match &prev {
            None => fm.advance_with_finger(
                &mut u,
                &fixed,
                (&zeros, &zeros),
                (&target, &fext),
                finger.as_ref().map(|(f, d)| (f, 0.0, *d)),
                steps,
            )?,
            Some(fa) => fm.advance_with_finger(
                &mut u,
                &fixed,
                (&target, fa),
                (&target, &fext),
                finger.as_ref().map(|(f, d)| (f, *d, *d)),
                2,
            )?,
        }
        let penetration_m = finger
            .as_ref()
            .map_or(0.0, |(f, d)| f.forces(mesh, &u, *d).1);
        out.push(TopState {
            t_s: t,
            stresses: fm.top_cauchy(&u),
            u: u.clone(),
            penetration_m,
        });
        prev = Some(fext);
    }
    Ok(out)
}

/// Nodal values of a Gauss-point field on one element (exposed for tests).
pub fn nodal(at_gauss: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    extrapolate_to_nodes(at_gauss)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(analysis: Analysis) {
        let m = Material::new(15e3, 0.45);
        let f = [[1.1, 0.15], [-0.05, 0.85]];
        let st = neo_hookean(&m, analysis, &f).unwrap();
        // dS/dE by central differences on C = FᵀF perturbed along each Voigt direction.
        let c = |f: &[[f64; 2]; 2]| {
            [
                f[0][0] * f[0][0] + f[1][0] * f[1][0],
                f[0][1] * f[0][1] + f[1][1] * f[1][1],
                f[0][0] * f[0][1] + f[1][0] * f[1][1],
            ]
        };
        // Build F from a symmetric C via F = sqrt(C) (2x2 closed form) so perturbations in E
        // map to valid F.
        let f_of_c = |cv: [f64; 3]| {
            let (a, d, b) = (cv[0], cv[1], cv[2]);
            let s = (a * d - b * b).sqrt();
            let t = (a + d + 2.0 * s).sqrt();
            [[(a + s) / t, b / t], [b / t, (d + s) / t]]
        };
        let c0 = c(&f);
        let h = 1e-6;
        for k in 0..3 {
            let mut cp = c0;
            let mut cm = c0;
            // E = (C - I)/2; Voigt strain uses 2 E12 = C12.
            let dc = if k == 2 { h } else { 2.0 * h };
            cp[k] += dc;
            cm[k] -= dc;
            let sp = neo_hookean(&m, analysis, &f_of_c(cp)).unwrap().s;
            let sm = neo_hookean(&m, analysis, &f_of_c(cm)).unwrap().s;
            for r in 0..3 {
                let fd = (sp[r] - sm[r]) / (2.0 * h);
                assert!(
                    (fd - st.d[r][k]).abs() < 1e-4 * st.d[0][0].abs(),
                    "{analysis:?} D[{r}][{k}] = {} vs fd {fd}",
                    st.d[r][k]
                );
            }
        }
    }

    #[test]
    fn tangent_matches_finite_differences() {
        fd_check(Analysis::PlaneStrain);
        fd_check(Analysis::PlaneStress);
    }

    #[test]
    fn small_strain_limit_is_the_linear_law() {
        let m = Material::new(1e4, 0.3);
        for analysis in [Analysis::PlaneStress, Analysis::PlaneStrain] {
            let st = neo_hookean(&m, analysis, &[[1.0, 0.0], [0.0, 1.0]]).unwrap();
            let l2 = m.lambda_2d_pa(analysis);
            assert!((st.d[0][0] - (l2 + 2.0 * m.mu_pa())).abs() < 1e-6);
            assert!((st.d[0][1] - l2).abs() < 1e-6);
            assert!((st.d[2][2] - m.mu_pa()).abs() < 1e-6);
            assert!(st.s.iter().all(|v| v.abs() < 1e-9));
        }
    }

    #[test]
    fn uniaxial_plane_stress_compression_matches_the_closed_form() {
        // A block squeezed by 25% between frictionless platens, sides free: the exact
        // neo-Hookean plane-stress state is homogeneous. Compare the Newton solution with a
        // direct scalar solve of the same constitutive law.
        use crate::mesher::{Density, mesh_block};
        let d = Density {
            near_size_m: 0.005,
            far_size_m: 0.005,
            min_layer_elements: 1,
            growth: 1.2,
        };
        let mesh = mesh_block(0.02, 0.01, None, &d).unwrap();
        let mat = Material::new(15e3, 0.45);
        let fm = FiniteModel::new(&mesh, &[mat], Analysis::PlaneStress).unwrap();
        let mut fixed = vec![false; mesh.dofs()];
        let mut target = vec![0.0; mesh.dofs()];
        for &n in &mesh.bottom {
            fixed[2 * n as usize + 1] = true;
        }
        fixed[2 * mesh.bottom[0] as usize] = true;
        for &n in &mesh.top {
            fixed[2 * n as usize + 1] = true;
            target[2 * n as usize + 1] = -0.0025;
        }
        let zeros = vec![0.0; mesh.dofs()];
        let mut u = zeros.clone();
        fm.advance(&mut u, &fixed, (&zeros, &zeros), (&target, &zeros), 4)
            .unwrap();
        let s = fm.top_cauchy(&u);
        // Closed form: F = diag(a, 0.75); find a with S11 = 0 (plane stress, free sides).
        let mut lo = 0.9;
        let mut hi = 1.6;
        for _ in 0..200 {
            let a = 0.5 * (lo + hi);
            let st = neo_hookean(&mat, Analysis::PlaneStress, &[[a, 0.0], [0.0, 0.75]]).unwrap();
            if st.s[0] > 0.0 {
                hi = a;
            } else {
                lo = a;
            }
        }
        let a = 0.5 * (lo + hi);
        let st = neo_hookean(&mat, Analysis::PlaneStress, &[[a, 0.0], [0.0, 0.75]]).unwrap();
        let sigma_yy = 0.75 * st.s[1] * 0.75 / st.j;
        for v in &s {
            assert!(
                (v[1] - sigma_yy).abs() < 1e-6 * sigma_yy.abs(),
                "{} vs {sigma_yy}",
                v[1]
            );
            assert!(v[0].abs() < 1e-6 * sigma_yy.abs());
        }
        // It is stiffer than the linear answer E·ε in compression? Not necessarily; it must
        // differ from it, which is the point of the option.
        assert!((sigma_yy.abs() - 15e3 * 0.25).abs() > 0.01 * 15e3 * 0.25);
    }

    /// A distorted element and a displacement that stretches, shears and rotates it.
    fn distorted() -> (Q4, [f64; 8]) {
        let q = Q4::new(&[
            [0.0, 0.0],
            [1.1e-3, 0.1e-3],
            [1.0e-3, 0.9e-3],
            [-0.1e-3, 1.2e-3],
        ])
        .unwrap();
        let ue = [
            0.0, 0.0, 0.15e-3, 0.05e-3, 0.1e-3, -0.12e-3, -0.05e-3, -0.2e-3,
        ];
        (q, ue)
    }

    #[test]
    fn the_mean_dilatation_tangent_is_the_derivative_of_its_forces() {
        let m = Material::new(15e3, 0.4999);
        let (q, ue) = distorted();
        let (_, k) = element_state(&q, &m, Analysis::PlaneStrain, &ue).unwrap();
        let h = 1e-9;
        let mut i = 0;
        for p in 0..8 {
            for c in p..8 {
                let mut up = ue;
                let mut um = ue;
                up[c] += h;
                um[c] -= h;
                let fp = element_state(&q, &m, Analysis::PlaneStrain, &up).unwrap().0;
                let fm = element_state(&q, &m, Analysis::PlaneStrain, &um).unwrap().0;
                let fd = (fp[p] - fm[p]) / (2.0 * h);
                assert!(
                    (fd - k[i]).abs() < 1e-5 * k[0].abs(),
                    "K[{p}][{c}] = {} vs fd {fd}",
                    k[i]
                );
                i += 1;
            }
        }
    }

    #[test]
    fn at_rest_the_plane_strain_tangent_is_the_linear_b_bar_element() {
        let (q, _) = distorted();
        for nu in [0.3, 0.4999] {
            let m = Material::new(15e3, nu);
            let (f, k) = element_state(&q, &m, Analysis::PlaneStrain, &[0.0; 8]).unwrap();
            let lin = q.stiffness_upper(&m, Analysis::PlaneStrain);
            assert!(f.iter().all(|v| v.abs() < 1e-12));
            for (a, b) in k.iter().zip(&lin) {
                assert!((a - b).abs() < 1e-9 * lin[0].abs(), "ν {nu}: {a} vs {b}");
            }
        }
    }

    /// Seed 001's healthy artery in plane strain at ν = 0.4999 under a hundredth of its load
    /// (strains of order 10⁻³): the finite-strain peak must be the linear B-bar one, on each
    /// mesh. Full 2x2 integration of the λ term locked here: peaks that moved with the mesh.
    #[test]
    fn near_incompressible_plane_strain_matches_the_linear_b_bar_at_small_load() {
        use crate::model::{Kinematics, Load, LumenPressure};
        use crate::run::run_model;
        let mut m = crate::study::shipped("seed-001-healthy-artery.ron").unwrap();
        m.analysis = Analysis::PlaneStrain;
        m.tissue.nu = 0.4999;
        if let Some(f) = m.feature.as_mut() {
            for l in &mut f.layers {
                l.material.nu = 0.4999;
            }
        }
        m.load = Load::Platen {
            indent_m: 0.0075 * 0.01,
        };
        m.lumen = m.lumen.take().map(|l| match l {
            LumenPressure::Pulse {
                diastolic_pa,
                systolic_pa,
                systole_s,
                period_s,
            } => LumenPressure::Pulse {
                diastolic_pa: diastolic_pa * 0.01,
                systolic_pa: systolic_pa * 0.01,
                systole_s,
                period_s,
            },
            other => other,
        });
        m.times_s = vec![0.425];
        let mut peaks = Vec::new();
        for refine in [0, 1] {
            m.kinematics = Kinematics::Linear;
            let lin = run_model(&m, refine).unwrap().times[0].summary.peak;
            m.kinematics = Kinematics::FiniteStrain { steps: 2 };
            let fin = run_model(&m, refine).unwrap().times[0].summary.peak;
            let rel = (fin - lin).abs() / lin;
            assert!(
                rel < 0.02,
                "refine {refine}: finite {fin} linear {lin} ({rel:.4})"
            );
            peaks.push(fin);
        }
        let drift = (peaks[1] - peaks[0]).abs() / peaks[1];
        assert!(
            drift < 0.03,
            "finite-strain peaks {peaks:?} move {drift:.4} with the mesh"
        );
    }
}
