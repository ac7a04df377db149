//! The finite-strain material and element: compressible neo-Hookean on a total Lagrangian
//! Q4, its internal forces, tangent and Cauchy stresses (the solver is [`super::finite`]).
//!
//! W = μ/2 (tr C - 3) - μ ln J + λ/2 (ln J)², which reduces to the linear law with the same
//! E and ν at small strain. S = μ (I - C⁻¹) + λ ln J C⁻¹. Plane strain has C₃₃ = 1; plane
//! stress finds C₃₃ at each Gauss point from S₃₃ = 0 (a scalar Newton solve) and condenses the
//! tangent.
//!
//! Plane strain near ν = 0.5 would lock under full 2x2 integration, as the linear element
//! would without its B-bar. So, as there, the λ term is the mean dilatation's: per element,
//! `V λ/2 (ln θ)²` with θ = v/V its deformed over reference area (the Q1/P0 mixed element
//! with its constant pressure condensed out; Simo, Taylor and Pister 1985, Bonet and Wood
//! section 8.6), while the μ terms stay at the Gauss points. It is an energy, so the tangent
//! stays symmetric and the Cholesky solver serves; F-bar's consistent tangent is not
//! symmetric. At small strain it is exactly the linear B-bar element. Plane stress does not
//! lock (λ condenses to a bounded λ₂) and keeps the full rule.

use super::element::{Q4, extrapolate_to_nodes};
use super::material::{Analysis, Material};

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
pub fn element_state(
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
    Some((fint, crate::element::pack_upper(&k)))
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
pub fn element_cauchy(q: &Q4, m: &Material, analysis: Analysis, ue: &[f64; 8]) -> [[f64; 4]; 4] {
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
}
