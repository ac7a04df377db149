//! The rod through the incision: where its tip truly is under load, and what it pushes on the
//! gimbal.
//!
//! The rod hangs from the gimbal point G (a ball joint: force, no moment), slides freely
//! through the pivot P (a lateral support, no axial force) and carries the sensor and the
//! added mass at its lower end. Loads perpendicular to the rod bend it as a beam supported at
//! G and P with an overhang `d` (the insertion depth) to the tip, and push the pivot aside
//! against its lateral stiffness. Both move the tip sideways by `c · F⊥` with
//!
//! ```text
//! c = d² L / (3 E I)  +  (L / a)² / k_pivot          a = |P − G|, d = L − a
//! ```
//!
//! (overhanging-beam tip deflection; the pivot reaction is `F (L / a)` and a pivot shift `s`
//! swings the tip by `s L / a` about G). Axial loads go to the gimbal. The rod's own inertia
//! and the tip's lateral inertia are ignored (quasi-static): the added mass accelerates at
//! most at the motion planner's 0.1 m/s², 0.03 N against newtons of friction.

use nalgebra::{Point3, Vector3};

use crate::scene::{MassSpec, ShaftSpec};

/// Standard gravity, m/s².
pub const GRAVITY_M_S2: f64 = 9.81;

/// The rod's true mechanical description.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rod {
    /// G to tip, m.
    pub length_m: f64,
    /// Bending stiffness E·I, N·m²; `None` for a rigid rod.
    pub bending_stiffness_nm2: Option<f64>,
    /// Lateral stiffness of the pivot, N/m; `None` for a rigid pivot.
    pub pivot_stiffness_n_per_m: Option<f64>,
    /// The rod's own mass, kg.
    pub rod_mass_kg: f64,
    /// The added mass and how far above the tip it hangs.
    pub mass_kg: f64,
    pub mass_height_m: f64,
}

impl Rod {
    pub fn new(
        length_m: f64,
        shaft: Option<&ShaftSpec>,
        pivot_stiffness_n_per_m: Option<f64>,
        mass: Option<&MassSpec>,
    ) -> Self {
        let (bending, rod_mass) = match shaft {
            Some(s) => {
                let r = s.diameter_m / 2.0;
                let second_moment = std::f64::consts::PI * s.diameter_m.powi(4) / 64.0;
                (
                    Some(s.youngs_modulus_pa * second_moment),
                    s.density_kg_m3 * std::f64::consts::PI * r * r * length_m,
                )
            }
            None => (None, 0.0),
        };
        Self {
            length_m,
            bending_stiffness_nm2: bending,
            pivot_stiffness_n_per_m,
            rod_mass_kg: rod_mass,
            mass_kg: mass.map_or(0.0, |m| m.mass_kg),
            mass_height_m: mass.map_or(0.0, |m| m.height_above_tip_m),
        }
    }

    /// Lateral tip compliance for gimbal-to-pivot distance `a`, m/N (0 when rigid).
    pub fn compliance_m_per_n(&self, a: f64) -> f64 {
        let l = self.length_m;
        let d = (l - a).max(0.0);
        let bend = self
            .bending_stiffness_nm2
            .map_or(0.0, |ei| d * d * l / (3.0 * ei));
        let pivot = self
            .pivot_stiffness_n_per_m
            .map_or(0.0, |k| (l / a.max(1e-3)).powi(2) / k);
        bend + pivot
    }

    /// The rod's axis and the undeflected tip for gimbal `g` and pivot `p`, or `None` if the
    /// gimbal sits on the pivot (no direction).
    pub fn rigid(&self, g: &Point3<f64>, p: &Point3<f64>) -> Option<RodGeometry> {
        let gp = p - g;
        let a = gp.norm();
        if a.is_nan() || a <= 1e-6 {
            return None;
        }
        let u = gp / a;
        Some(RodGeometry {
            axis: u,
            gimbal_to_pivot_m: a,
            tip: g + self.length_m * u,
        })
    }

    /// The force the rod pushes on the gimbal, robot base frame, N, given the tissue's force
    /// on the sensor (`tip_force`) and gravity on the rod and the added mass.
    pub fn gimbal_force(&self, geom: &RodGeometry, tip_force: &Vector3<f64>) -> Vector3<f64> {
        let u = geom.axis;
        let a = geom.gimbal_to_pivot_m;
        let down = Vector3::new(0.0, -GRAVITY_M_S2, 0.0);
        // (load, distance from G along the rod)
        let loads = [
            (*tip_force, self.length_m),
            (down * self.mass_kg, self.length_m - self.mass_height_m),
            (down * self.rod_mass_kg, self.length_m / 2.0),
        ];
        let mut f = Vector3::zeros();
        for (q, s) in loads {
            let axial = q.dot(&u) * u;
            // The pivot takes the rest of the perpendicular load by the lever about G.
            f += axial + (q - axial) * (1.0 - s / a);
        }
        f
    }

    /// Loads other than the tissue's lateral friction that act perpendicular to the rod near
    /// its tip (the normal force and the added mass's weight on a tilted rod), N.
    pub fn perpendicular_load(&self, geom: &RodGeometry, normal_n: f64) -> Vector3<f64> {
        let u = geom.axis;
        let q = Vector3::new(0.0, normal_n - self.mass_kg * GRAVITY_M_S2, 0.0);
        q - q.dot(&u) * u
    }

    /// Mass reflected to the gimbal: axial motion carries the whole rod and mass; lateral
    /// motion swings them about the pivot. Returns (axial, lateral), kg.
    pub fn reflected_mass_kg(&self, a: f64) -> (f64, f64) {
        let l = self.length_m;
        let d = (l - a).max(0.0);
        let axial = self.rod_mass_kg + self.mass_kg;
        let rod_about_pivot = self.rod_mass_kg * (a.powi(3) + d.powi(3)) / (3.0 * l);
        let mass_about_pivot = self.mass_kg * (d - self.mass_height_m).powi(2);
        let lateral = (rod_about_pivot + mass_about_pivot) / (a * a).max(1e-6);
        (axial, lateral)
    }
}

/// The undeflected rod at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodGeometry {
    /// Unit vector from G toward the tip.
    pub axis: Vector3<f64>,
    pub gimbal_to_pivot_m: f64,
    pub tip: Point3<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel_rod() -> Rod {
        let shaft = ShaftSpec {
            diameter_m: 0.0045,
            youngs_modulus_pa: 200e9,
            density_kg_m3: 7850.0,
            length_m: None,
        };
        Rod::new(
            0.495,
            Some(&shaft),
            None,
            Some(&MassSpec {
                mass_kg: 0.3,
                height_above_tip_m: 0.03,
            }),
        )
    }

    #[test]
    fn bending_compliance_matches_the_overhanging_beam() {
        let rod = steel_rod();
        let ei = rod.bending_stiffness_nm2.unwrap();
        // E I of a 4.5 mm steel rod: about 4.03 N·m².
        assert!((ei - 4.026).abs() < 0.01, "{ei}");
        // 0.3 m below the pivot: 3.7 mm/N.
        let c = rod.compliance_m_per_n(0.195);
        assert!((c - 0.09 * 0.495 / (3.0 * ei)).abs() < 1e-12);
        assert!((c * 1e3 - 3.69).abs() < 0.02, "{c}");
        // Rigid in both: no compliance.
        let rigid = Rod::new(0.495, None, None, None);
        assert_eq!(rigid.compliance_m_per_n(0.195), 0.0);
    }

    #[test]
    fn gimbal_force_balances_moments_about_the_pivot() {
        let rod = Rod::new(0.495, None, None, None);
        let g = Point3::new(0.0, 0.0, 0.0);
        let p = Point3::new(0.0, -0.195, 0.0);
        let geom = rod.rigid(&g, &p).unwrap();
        // A lateral push at the tip comes back mirrored through the lever d / a.
        let f = rod.gimbal_force(&geom, &Vector3::new(1.0, 0.0, 0.0));
        assert!((f.x + 0.3 / 0.195).abs() < 1e-12, "{f:?}");
        // An upward push goes straight up the rod to the gimbal.
        let f = rod.gimbal_force(&geom, &Vector3::new(0.0, 2.0, 0.0));
        assert!((f - Vector3::new(0.0, 2.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn weight_is_carried_axially_when_vertical() {
        let rod = steel_rod();
        let g = Point3::new(0.0, 0.0, 0.0);
        let p = Point3::new(0.0, -0.2, 0.0);
        let geom = rod.rigid(&g, &p).unwrap();
        let f = rod.gimbal_force(&geom, &Vector3::zeros());
        let w = (rod.mass_kg + rod.rod_mass_kg) * GRAVITY_M_S2;
        assert!((f.y + w).abs() < 1e-9 && f.x.abs() < 1e-12);
        // And resting on the tissue with N = W, the gimbal carries nothing.
        let f = rod.gimbal_force(&geom, &Vector3::new(0.0, w, 0.0));
        assert!(f.norm() < 1e-9);
    }
}
