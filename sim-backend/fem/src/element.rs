//! The 4-node bilinear quadrilateral (Q4) for small-strain elasticity.
//!
//! Deviatoric (μ) stiffness is integrated with 2x2 Gauss points. In plane strain the
//! volumetric (λ) part uses the mean dilatation over the element (B-bar with a constant
//! pressure), which removes volumetric locking as ν -> 0.5; in plane stress λ₂ stays bounded
//! and the full 2x2 rule is used. Nodes are counter-clockwise.

use super::material::{Analysis, Material};

/// Gauss points of the 2x2 rule (weights are all 1).
pub const GAUSS: f64 = 0.577_350_269_189_625_8;
pub const GAUSS_POINTS: [[f64; 2]; 4] = [
    [-GAUSS, -GAUSS],
    [GAUSS, -GAUSS],
    [GAUSS, GAUSS],
    [-GAUSS, GAUSS],
];
/// Natural coordinates of the nodes.
pub const NODE_XI: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Shape-function derivatives in physical coordinates at one point, and det J.
#[derive(Debug, Clone, Copy)]
pub struct ShapeGrad {
    /// dN_a/dx, dN_a/dy.
    pub dn: [[f64; 2]; 4],
    pub det_j: f64,
}

/// Gradients of the shape functions at natural point (ξ, η). `None` if the element is
/// inverted or degenerate there (det J <= 0).
pub fn shape_grad(x: &[[f64; 2]; 4], xi: f64, eta: f64) -> Option<ShapeGrad> {
    let mut dxi = [[0.0; 2]; 4];
    for (a, n) in NODE_XI.iter().enumerate() {
        dxi[a][0] = 0.25 * n[0] * (1.0 + eta * n[1]);
        dxi[a][1] = 0.25 * n[1] * (1.0 + xi * n[0]);
    }
    let mut j = [[0.0; 2]; 2];
    for a in 0..4 {
        for r in 0..2 {
            for c in 0..2 {
                j[r][c] += dxi[a][c] * x[a][r];
            }
        }
    }
    // j[r][c] = d x_r / d ξ_c
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if det.is_nan() || det <= 0.0 || !det.is_finite() {
        return None;
    }
    let inv = [
        [j[1][1] / det, -j[0][1] / det],
        [-j[1][0] / det, j[0][0] / det],
    ];
    let mut dn = [[0.0; 2]; 4];
    for a in 0..4 {
        // dN/dx_r = dN/dξ_c dξ_c/dx_r, dξ/dx = inv(J)
        for r in 0..2 {
            dn[a][r] = dxi[a][0] * inv[0][r] + dxi[a][1] * inv[1][r];
        }
    }
    Some(ShapeGrad { dn, det_j: det })
}

/// Shape functions at (ξ, η).
pub fn shape(xi: f64, eta: f64) -> [f64; 4] {
    let mut n = [0.0; 4];
    for (a, p) in NODE_XI.iter().enumerate() {
        n[a] = 0.25 * (1.0 + xi * p[0]) * (1.0 + eta * p[1]);
    }
    n
}

/// Why an element could not be formed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("element is inverted or degenerate (det J <= 0)")]
pub struct BadElement;

/// Strain-displacement rows for (εxx, εyy, γxy) at one point.
fn b_matrix(g: &ShapeGrad) -> [[f64; 8]; 3] {
    let mut b = [[0.0; 8]; 3];
    for a in 0..4 {
        b[0][2 * a] = g.dn[a][0];
        b[1][2 * a + 1] = g.dn[a][1];
        b[2][2 * a] = g.dn[a][1];
        b[2][2 * a + 1] = g.dn[a][0];
    }
    b
}

/// Precomputed geometry of one element: B at the Gauss points, their weights, and the mean
/// dilatation row b̄ = (1/A) ∫ m·B dA.
#[derive(Debug, Clone, Copy)]
pub struct Q4 {
    pub b: [[[f64; 8]; 3]; 4],
    pub w: [f64; 4],
    pub b_mean: [f64; 8],
    pub area: f64,
}

impl Q4 {
    pub fn new(x: &[[f64; 2]; 4]) -> Result<Self, BadElement> {
        let mut b = [[[0.0; 8]; 3]; 4];
        let mut w = [0.0; 4];
        let mut b_mean = [0.0; 8];
        let mut area = 0.0;
        for (g, p) in GAUSS_POINTS.iter().enumerate() {
            let sg = shape_grad(x, p[0], p[1]).ok_or(BadElement)?;
            b[g] = b_matrix(&sg);
            w[g] = sg.det_j;
            area += sg.det_j;
            for i in 0..8 {
                b_mean[i] += (b[g][0][i] + b[g][1][i]) * sg.det_j;
            }
        }
        for v in &mut b_mean {
            *v /= area;
        }
        Ok(Self { b, w, b_mean, area })
    }

    /// Whether the volumetric term uses the mean dilatation (plane strain) or the 2x2 rule.
    fn mean_dilatation(analysis: Analysis) -> bool {
        analysis == Analysis::PlaneStrain
    }

    /// Upper triangle (row-major, p <= q) of the 8x8 stiffness: 36 values.
    pub fn stiffness_upper(&self, m: &Material, analysis: Analysis) -> [f64; 36] {
        let mu = m.mu_pa();
        let lam = m.lambda_2d_pa(analysis);
        let bbar = Self::mean_dilatation(analysis);
        let mut k = [[0.0; 8]; 8];
        for g in 0..4 {
            let b = &self.b[g];
            let w = self.w[g];
            for p in 0..8 {
                // μ diag(2,2,1) B, column p
                let s0 = 2.0 * mu * b[0][p] * w;
                let s1 = 2.0 * mu * b[1][p] * w;
                let s2 = mu * b[2][p] * w;
                let dil_p = b[0][p] + b[1][p];
                for q in p..8 {
                    let mut v = s0 * b[0][q] + s1 * b[1][q] + s2 * b[2][q];
                    if !bbar {
                        v += lam * dil_p * (b[0][q] + b[1][q]) * w;
                    }
                    k[p][q] += v;
                }
            }
        }
        if bbar {
            for p in 0..8 {
                for q in p..8 {
                    k[p][q] += lam * self.area * self.b_mean[p] * self.b_mean[q];
                }
            }
        }
        pack_upper(&k)
    }

    /// Stress (σxx, σyy, σxy, σzz) at each Gauss point for element displacements `u`.
    pub fn stresses(&self, m: &Material, analysis: Analysis, u: &[f64; 8]) -> [[f64; 4]; 4] {
        let mu = m.mu_pa();
        let lam = m.lambda_2d_pa(analysis);
        let mean_dil: f64 = self.b_mean.iter().zip(u).map(|(b, u)| b * u).sum();
        let mut out = [[0.0; 4]; 4];
        for g in 0..4 {
            let mut e = [0.0; 3];
            for (r, row) in self.b[g].iter().enumerate() {
                e[r] = row.iter().zip(u).map(|(b, u)| b * u).sum();
            }
            let dil = if Self::mean_dilatation(analysis) {
                mean_dil
            } else {
                e[0] + e[1]
            };
            let szz = match analysis {
                Analysis::PlaneStrain => lam * dil,
                Analysis::PlaneStress => 0.0,
            };
            out[g] = [
                lam * dil + 2.0 * mu * e[0],
                lam * dil + 2.0 * mu * e[1],
                mu * e[2],
                szz,
            ];
        }
        out
    }
}

/// Extrapolate values at the 2x2 Gauss points to the four nodes (bilinear through the
/// Gauss points, evaluated at ξ, η = ±√3).
pub fn extrapolate_to_nodes(at_gauss: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    let s = 3f64.sqrt();
    let mut out = [[0.0; 4]; 4];
    for (a, n) in NODE_XI.iter().enumerate() {
        // In the Gauss-point coordinate system the nodes sit at ±√3.
        let w = shape(n[0] * s, n[1] * s);
        for (g, wg) in w.iter().enumerate() {
            for c in 0..4 {
                out[a][c] += wg * at_gauss[g][c];
            }
        }
    }
    out
}

/// The upper triangle of an 8x8 element matrix, row by row (36 values): what assembly reads.
pub(crate) fn pack_upper(k: &[[f64; 8]; 8]) -> [f64; 36] {
    let mut out = [0.0; 36];
    let mut i = 0;
    for (p, row) in k.iter().enumerate() {
        for &v in &row[p..] {
            out[i] = v;
            i += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_square() -> [[f64; 2]; 4] {
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    }

    fn full(k: &[f64; 36]) -> [[f64; 8]; 8] {
        let mut m = [[0.0; 8]; 8];
        let mut i = 0;
        for p in 0..8 {
            for q in p..8 {
                m[p][q] = k[i];
                m[q][p] = k[i];
                i += 1;
            }
        }
        m
    }

    #[test]
    fn rigid_body_modes_have_no_energy_and_stiffness_has_rank_five() {
        let x = [[0.1, 0.0], [1.2, 0.2], [1.0, 1.1], [-0.1, 0.9]];
        let q = Q4::new(&x).unwrap();
        for analysis in [Analysis::PlaneStrain, Analysis::PlaneStress] {
            let k = full(&q.stiffness_upper(&Material::new(1e4, 0.4999), analysis));
            let modes: [[f64; 8]; 3] = {
                let mut t = [[0.0; 8]; 3];
                for a in 0..4 {
                    t[0][2 * a] = 1.0;
                    t[1][2 * a + 1] = 1.0;
                    t[2][2 * a] = -x[a][1];
                    t[2][2 * a + 1] = x[a][0];
                }
                t
            };
            for m in &modes {
                for row in &k {
                    let f: f64 = row.iter().zip(m).map(|(a, b)| a * b).sum();
                    assert!(f.abs() < 1e-6 * 1e4, "rigid mode force {f}");
                }
            }
        }
    }

    #[test]
    fn extrapolation_reproduces_a_bilinear_field() {
        let x = unit_square();
        let f = |p: [f64; 2]| 1.0 + 2.0 * p[0] - 3.0 * p[1] + 0.5 * p[0] * p[1];
        let mut g = [[0.0; 4]; 4];
        for (i, p) in GAUSS_POINTS.iter().enumerate() {
            g[i] = [f(*p); 4];
        }
        let n = extrapolate_to_nodes(&g);
        for (a, p) in NODE_XI.iter().enumerate() {
            assert!((n[a][0] - f(*p)).abs() < 1e-12);
        }
        let _ = x;
    }

    #[test]
    fn inverted_element_is_refused() {
        let x = [[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
        assert!(Q4::new(&x).is_err());
    }
}
