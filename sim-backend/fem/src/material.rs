//! Isotropic linear-elastic materials and the 2-D reductions (plane stress, plane strain).

use serde::{Deserialize, Serialize};

/// Which 2-D idealization of the 3-D body is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Analysis {
    /// Thin slab, σzz = 0 (both seed FEM papers use it).
    PlaneStress,
    /// Long body, εzz = 0 (a tube's cross-section; the sim kernel uses it).
    PlaneStrain,
}

/// Young's modulus and Poisson's ratio.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub e_pa: f64,
    pub nu: f64,
}

impl Material {
    pub const fn new(e_pa: f64, nu: f64) -> Self {
        Self { e_pa, nu }
    }

    /// Shear modulus μ.
    pub fn mu_pa(&self) -> f64 {
        self.e_pa / (2.0 * (1.0 + self.nu))
    }

    /// 3-D Lamé λ (grows without bound as ν -> 0.5).
    pub fn lambda_pa(&self) -> f64 {
        self.e_pa * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
    }

    /// The λ that multiplies the in-plane dilatation in the 2-D stress law
    /// σ = λ₂ (εxx + εyy) m + μ diag(2, 2, 1) ε. Plane stress condenses σzz = 0 out,
    /// which keeps λ₂ bounded (no locking); plane strain keeps the 3-D λ.
    pub fn lambda_2d_pa(&self, analysis: Analysis) -> f64 {
        let (l, m) = (self.lambda_pa(), self.mu_pa());
        match analysis {
            Analysis::PlaneStrain => l,
            Analysis::PlaneStress => 2.0 * l * m / (l + 2.0 * m),
        }
    }

    /// A material is usable if E > 0 and -1 < ν < 0.5.
    pub fn is_valid(&self) -> bool {
        self.e_pa.is_finite()
            && self.e_pa > 0.0
            && self.nu.is_finite()
            && self.nu > -1.0
            && self.nu < 0.5
    }
}

/// Von Mises equivalent stress from (σxx, σyy, σxy) and σzz.
pub fn von_mises(sxx: f64, syy: f64, sxy: f64, szz: f64) -> f64 {
    let a = sxx - syy;
    let b = syy - szz;
    let c = szz - sxx;
    (0.5 * (a * a + b * b + c * c) + 3.0 * sxy * sxy).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_stress_lambda_matches_the_textbook_matrix() {
        let m = Material::new(1000.0, 0.3);
        let l2 = m.lambda_2d_pa(Analysis::PlaneStress);
        // D11 = E / (1 - ν²), D12 = ν E / (1 - ν²)
        let d11 = l2 + 2.0 * m.mu_pa();
        assert!((d11 - 1000.0 / (1.0 - 0.09)).abs() < 1e-9);
        assert!((l2 - 300.0 / (1.0 - 0.09)).abs() < 1e-9);
    }

    #[test]
    fn von_mises_of_uniaxial_and_pure_shear() {
        assert!((von_mises(5.0, 0.0, 0.0, 0.0) - 5.0).abs() < 1e-12);
        assert!((von_mises(0.0, 0.0, 2.0, 0.0) - 2.0 * 3f64.sqrt()).abs() < 1e-12);
        assert!(von_mises(3.0, 3.0, 0.0, 3.0).abs() < 1e-12);
    }
}
