//! Tactile frames synthesized from FEM surface stresses: what the 10-element array would read
//! over a model, used to validate `control::classify` on the papers' four models.

use control::types::{ELEMENTS, TactileFrame};

use super::recovery::interpolate;
use super::run::TimeResult;

/// The sensor over the top surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArrayPlacement {
    /// Lateral offset of the array's centre from the model's origin (the feature), m.
    pub centre_x_m: f64,
    pub pitch_m: f64,
    /// Element area, m² (the seed's 2 x 2 mm elements: 4e-6).
    pub element_area_m2: f64,
}

impl Default for ArrayPlacement {
    fn default() -> Self {
        Self {
            centre_x_m: 0.001,
            pitch_m: 0.002,
            element_area_m2: 4e-6,
        }
    }
}

/// Element forces (N, compressive positive) from one time's top σyy.
pub fn element_forces(t: &TimeResult, placement: &ArrayPlacement) -> [f64; ELEMENTS] {
    let mut f = [0.0; ELEMENTS];
    let mid = (ELEMENTS as f64 - 1.0) / 2.0;
    for (e, v) in f.iter_mut().enumerate() {
        let x = placement.centre_x_m + (e as f64 - mid) * placement.pitch_m;
        *v = -interpolate(&t.x_m, &t.sigma_yy_pa, x) * placement.element_area_m2;
    }
    f
}

/// Frames at `rate_hz` for `duration_s` from two solved states (diastole and systole): a
/// linear model's surface stress is affine in the lumen pressure, so any pressure in between
/// is interpolated exactly. `pressure01(t)` gives the pulse from 0 (diastole) to 1 (systole);
/// `noise(i, e)` adds sensor noise.
pub fn synthesize(
    diastole: &TimeResult,
    systole: &TimeResult,
    placement: &ArrayPlacement,
    rate_hz: f64,
    duration_s: f64,
    pressure01: impl Fn(f64) -> f64,
    mut noise: impl FnMut() -> f64,
) -> Vec<TactileFrame> {
    let fd = element_forces(diastole, placement);
    let fs = element_forces(systole, placement);
    let n = (duration_s * rate_hz).round() as usize;
    (0..n)
        .map(|i| {
            let t = i as f64 / rate_hz;
            let s = pressure01(t);
            let mut force_n = [0.0; ELEMENTS];
            for e in 0..ELEMENTS {
                force_n[e] = fd[e] + s * (fs[e] - fd[e]) + noise();
            }
            TactileFrame {
                t_s: t,
                seq: i as u64,
                force_n,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::shipped;
    use control::classify::{ClassifyParams, Kind, Window};

    struct Gauss(u64);
    impl Gauss {
        fn next(&mut self) -> f64 {
            let mut u = || {
                self.0 ^= self.0 << 13;
                self.0 ^= self.0 >> 7;
                self.0 ^= self.0 << 17;
                ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        }
    }

    /// Paper 001's pulse: 80 -> 120 mmHg over 0.425 s and back, period 0.85 s.
    fn pulse(t: f64) -> f64 {
        let ph = (t / 0.85).fract();
        if ph < 0.5 { 2.0 * ph } else { 2.0 - 2.0 * ph }
    }

    fn window_for(model: &str, noise_sd_n: f64, seed: u64) -> (Window, f64) {
        let mut m = shipped(model).unwrap();
        m.times_s = vec![0.0, 0.425];
        let run = crate::run::run_model(&m, 0).unwrap();
        let p = ArrayPlacement::default();
        let mut g = Gauss(seed);
        let frames = synthesize(&run.times[0], &run.times[1], &p, 100.0, 6.0, pulse, || {
            noise_sd_n * g.next()
        });
        let fd = element_forces(&run.times[0], &p);
        let fs = element_forces(&run.times[1], &p);
        let swing = fd
            .iter()
            .zip(&fs)
            .map(|(a, b)| (b - a).abs())
            .fold(0.0, f64::max);
        let mut w = Window::new(frames.len());
        for f in &frames {
            w.push(f).unwrap();
        }
        (w, swing)
    }

    #[test]
    fn the_classifier_tells_the_four_paper_001_models_apart_on_fem_frames() {
        // The papers' 15 kPa tissue and 40 mmHg pulse move a 2 x 2 mm element by well under a
        // millinewton, far below the seed sensor's 0.012 N noise. Test at a noise SD of a
        // third of the healthy artery's largest element swing, where the pulse is visible in
        // a 6 s window; the seed-noise case is the sim's business (longer windows).
        let (_, healthy_swing) = window_for("seed-001-healthy-artery.ron", 0.0, 1);
        let sd = healthy_swing / 3.0;
        let params = ClassifyParams {
            noise_sd_n: sd,
            uniform_tolerance_n: 0.0,
            uniform_tolerance_rel: 0.01,
            ..ClassifyParams::default()
        };
        let classify = |model: &str, seed: u64, reference| {
            let (w, _) = window_for(model, sd, seed);
            w.classify(&params, reference).unwrap()
        };
        let tissue = classify("seed-001-tissue.ron", 2, None);
        assert_eq!(tissue.kind, Kind::Tissue, "{tissue:?}");
        let tumour = classify("seed-001-tumour.ron", 3, None);
        assert_eq!(tumour.kind, Kind::Lump, "{tumour:?}");
        let healthy = classify("seed-001-healthy-artery.ron", 4, None);
        assert_eq!(healthy.kind, Kind::Artery, "{healthy:?}");
        let stenotic = classify("seed-001-stenotic-artery.ron", 5, Some(&healthy.features));
        assert_eq!(stenotic.kind, Kind::ArteryStenosisSuspected, "{stenotic:?}");
        // And the other way round: the healthy artery is not stenotic next to the stenotic.
        let back = classify("seed-001-healthy-artery.ron", 6, Some(&stenotic.features));
        assert_eq!(back.kind, Kind::Artery, "{back:?}");
        for c in [tissue, tumour, healthy, stenotic, back] {
            assert!(c.confidence > 0.5, "{c:?}");
        }
    }
}
