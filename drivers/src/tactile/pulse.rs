//! A synthetic pulsing artery under the array: a stand-in for the simulator's sensor model
//! that feeds the emulator.
//!
//! The pulsatile pressure under a rigid flat contact above a tube of inner radius `a` at
//! depth `h` with pulse pressure Δp is (DESIGN.md section 5)
//! `p(x) = 2 Δp a² (h² − x²) / (x² + h²)²`, x the lateral distance from the tube's axis;
//! each element feels it over its area, on top of a static contact preload, plus Gaussian
//! noise.

use control::sensor::ArrayGeometry;
use control::types::ELEMENTS;

/// The seed's bench by default: a latex tube of 5 mm OD and 1 mm wall (a = 1.5 mm) 5 mm deep,
/// inflated to 100 kPa and vented once a second, felt by 2 x 2 mm elements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseScene {
    /// Lateral position of the tube's axis relative to the sensor centre, m (tissue `z`).
    pub artery_z_m: f64,
    pub depth_m: f64,
    pub inner_radius_m: f64,
    pub pulse_pressure_pa: f64,
    pub heart_rate_hz: f64,
    /// Fraction of each period the tube is inflated (the seed's solenoid: a square wave).
    pub duty: f64,
    pub element_area_m2: f64,
    /// Static contact force on every element, N.
    pub preload_n: f64,
    pub noise_sd_n: f64,
    pub geometry: ArrayGeometry,
    pub seed: u64,
}

impl Default for PulseScene {
    fn default() -> Self {
        Self {
            artery_z_m: 0.0,
            depth_m: 0.005,
            inner_radius_m: 0.0015,
            pulse_pressure_pa: 100.0e3,
            heart_rate_hz: 1.0,
            duty: 0.5,
            element_area_m2: 0.002 * 0.002,
            preload_n: 0.3,
            noise_sd_n: 0.012,
            geometry: ArrayGeometry::default(),
            seed: 1,
        }
    }
}

/// Produces force frames from a [`PulseScene`].
#[derive(Debug, Clone)]
pub struct SyntheticPulse {
    scene: PulseScene,
    noise: GaussianNoise,
}

impl SyntheticPulse {
    pub fn new(scene: PulseScene) -> Self {
        Self {
            scene,
            noise: GaussianNoise::new(scene.seed),
        }
    }

    /// Pulsatile pressure at lateral distance `x_m` from the tube's axis at full inflation, Pa.
    pub fn pressure_pa(&self, x_m: f64) -> f64 {
        let s = &self.scene;
        let (a, h) = (s.inner_radius_m, s.depth_m);
        let d = x_m * x_m + h * h;
        2.0 * s.pulse_pressure_pa * a * a * (h * h - x_m * x_m) / (d * d)
    }

    /// Inflation at time `t_s`, 0 or 1.
    pub fn inflation(&self, t_s: f64) -> f64 {
        let phase = (t_s * self.scene.heart_rate_hz).rem_euclid(1.0);
        if phase < self.scene.duty { 1.0 } else { 0.0 }
    }

    /// Noise-free force on element `i` at time `t_s`, N.
    pub fn clean_force_n(&self, i: usize, t_s: f64) -> f64 {
        let s = &self.scene;
        let x = s.geometry.offset_z_m(i as f64) - s.artery_z_m;
        s.preload_n + self.inflation(t_s) * self.pressure_pa(x) * s.element_area_m2
    }

    pub fn sample(&mut self, t_s: f64) -> [f64; ELEMENTS] {
        let mut out = [0.0; ELEMENTS];
        for (i, f) in out.iter_mut().enumerate() {
            *f = self.clean_force_n(i, t_s) + self.scene.noise_sd_n * self.noise.sample();
        }
        out
    }
}

/// Standard normal deviates: SplitMix64 into Box–Muller. Deterministic for a seed.
#[derive(Debug, Clone)]
pub struct GaussianNoise {
    state: u64,
    spare: Option<f64>,
}

impl GaussianNoise {
    pub fn new(seed: u64) -> Self {
        Self {
            state: seed,
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1].
    fn unit(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }

    pub fn sample(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let (u1, u2) = (self.unit(), self.unit());
        let r = (-2.0 * u1.ln()).sqrt();
        let th = std::f64::consts::TAU * u2;
        self.spare = Some(r * th.sin());
        r * th.cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seed_tube_gives_about_seventy_millinewtons_over_the_axis() {
        let p = SyntheticPulse::new(PulseScene::default());
        // 2 Δp a²/h² = 2 * 1e5 * (1.5/5)² = 18 kPa; on 4 mm² that is 0.072 N.
        assert!((p.pressure_pa(0.0) - 18_000.0).abs() < 1e-6);
        // Zero crossing at |x| = h, negative beyond (the far elements move out of phase).
        assert!(p.pressure_pa(0.005).abs() < 1e-9);
        assert!(p.pressure_pa(0.008) < 0.0);
        // The element nearest the axis swings most.
        let scene = PulseScene {
            artery_z_m: 0.003, // between elements 5 (z = 1 mm) and 6 (z = 3 mm): at 6
            ..PulseScene::default()
        };
        let p = SyntheticPulse::new(scene);
        let swing: Vec<f64> = (0..ELEMENTS)
            .map(|i| p.clean_force_n(i, 0.25) - p.clean_force_n(i, 0.75))
            .collect();
        let best = (0..ELEMENTS)
            .max_by(|&a, &b| swing[a].total_cmp(&swing[b]))
            .expect("ten elements");
        assert_eq!(best, 6);
        assert!((swing[6] - 0.072).abs() < 1e-9);
    }

    #[test]
    fn noise_has_unit_variance() {
        let mut g = GaussianNoise::new(7);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| g.sample()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "variance {var}");
    }
}
