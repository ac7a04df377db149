//! The detector on synthetic frames: the kernel family, the generic waveform, Gaussian
//! noise from `test_normals`, and a heart whose beat intervals vary as a real one's.

use super::*;
use crate::signal::detection_bound::{self, glrt_threshold, per_beat, snr_needed, waveform_energy};
use crate::signal::kernel_fit::element_kernel;
use crate::test_normals::Normals;

const SIGMA: f64 = 0.012;
const FS: f64 = 100.0;
const PITCH: f64 = 0.002;
const WIDTH: f64 = 0.005;

fn settings(limit_s: f64) -> WeakPulseSettings {
    WeakPulseSettings {
        limit_s,
        ..WeakPulseSettings::default()
    }
}

/// Beat onsets over `span_s` for a mean period `t0`: respiratory modulation (4 %, 0.25 Hz),
/// a slow wander (AR(1), 3 %) and beat-to-beat scatter (2 %): interval SD about 4.6 %.
fn beats(t0: f64, span_s: f64, rng: &mut Normals) -> Vec<(f64, f64)> {
    let mut t = -t0 * rng.uniform();
    let (mut wander, psi) = (0.0, std::f64::consts::TAU * rng.uniform());
    let mut out = Vec::new();
    while t < span_s + 2.0 {
        wander = 0.95 * wander + 0.03 * (1.0f64 - 0.95 * 0.95).sqrt() * rng.next();
        let rsa = 0.04 * (std::f64::consts::TAU * 0.25 * t + psi).sin();
        let rr = t0 * (1.0 + rsa + wander + 0.02 * rng.next());
        out.push((t, rr));
        t += rr;
    }
    out
}

/// What the array feels.
#[derive(Clone, Copy)]
struct Scene {
    /// Artery offset along the array, m, and its pulse's peak force on the nearest
    /// element, N (0 for none).
    x0_m: f64,
    amplitude_n: f64,
    period_s: f64,
    /// A static lump (peak force, N, at 2 mm) and a drift (N/s, and a slow swell, N).
    lump_n: f64,
    drift_n_per_s: f64,
    swell_n: f64,
}

impl Scene {
    fn noise() -> Self {
        Self {
            x0_m: 0.0,
            amplitude_n: 0.0,
            period_s: 0.85,
            lump_n: 0.0,
            drift_n_per_s: 0.0,
            swell_n: 0.0,
        }
    }
}

fn kernel_at(x0: f64) -> [f64; ELEMENTS] {
    std::array::from_fn(|e| element_kernel((e as f64 - 4.5) * PITCH - x0, WIDTH, PITCH))
}

/// Feed `detector` the scene until it decides; the decision and the last progress.
fn run(
    detector: &mut WeakPulseDetector,
    scene: Scene,
    rng: &mut Normals,
) -> (Decision, Vec<Progress>) {
    let span = 400.0;
    let onsets = if scene.amplitude_n > 0.0 {
        beats(scene.period_s, span, rng)
    } else {
        Vec::new()
    };
    let s = kernel_at(scene.x0_m);
    let peak = s.iter().copied().fold(0.0, f64::max);
    let lump = kernel_at(0.002);
    let mut beat = 0;
    let mut progress = Vec::new();
    for i in 0.. {
        let t = i as f64 / FS;
        while beat + 1 < onsets.len() && onsets[beat + 1].0 <= t {
            beat += 1;
        }
        let pulse = onsets
            .get(beat)
            .filter(|(t0, _)| *t0 <= t)
            .map_or(0.0, |&(t0, rr)| generic_pressure(t - t0, rr));
        let drift =
            scene.drift_n_per_s * t + scene.swell_n * (std::f64::consts::TAU * t / 40.0).sin();
        let frame = TactileFrame {
            t_s: t,
            seq: i,
            force_n: std::array::from_fn(|e| {
                scene.amplitude_n * s[e] / peak * pulse
                    + scene.lump_n * lump[e]
                    + drift
                    + SIGMA * rng.next()
            }),
        };
        if let Some(p) = detector.push(&frame).expect("a good frame") {
            progress.push(p);
            if let Some(d) = p.decision {
                return (d, progress);
            }
        }
    }
    unreachable!()
}

fn three_se(p: f64, n: usize) -> f64 {
    3.0 * (p * (1.0 - p) / n as f64).sqrt()
}

fn law(limit_s: f64, draws: usize, seed: u64) -> NoiseLaw {
    let mut rng = Normals::new(seed);
    NoiseLaw::measure(&settings(limit_s), &PulseShape::Generic, draws, &mut || {
        rng.next()
    })
    .expect("law")
}

fn detector(threshold: &Threshold) -> WeakPulseDetector {
    WeakPulseDetector::new(
        settings(threshold.settings.limit_s),
        PulseShape::Generic,
        threshold,
    )
    .expect("detector")
}

#[test]
fn noise_only_windows_of_every_length_alarm_at_the_designed_rate() {
    let pfa = 0.05;
    let law = law(45.0, 800, 1);
    let mut rng = Normals::new(2);
    let trials = 500;
    let mut last = f64::NEG_INFINITY;
    for limit in [9.0, 24.0, 45.0] {
        let threshold = law.threshold(pfa, limit).expect("threshold");
        // Averaged likelihood ratio: its sup stays under ln(1/pfa) (Ville) at every length,
        // and a longer window needs a higher one.
        assert!(
            threshold.log_ratio < (1.0 / pfa).ln(),
            "{limit} s: {}",
            threshold.log_ratio
        );
        assert!(threshold.log_ratio >= last);
        last = threshold.log_ratio;
        let alarms = (0..trials)
            .filter(|_| {
                matches!(
                    run(&mut detector(&threshold), Scene::noise(), &mut rng).0,
                    Decision::Found(_)
                )
            })
            .count();
        let rate = alarms as f64 / trials as f64;
        eprintln!(
            "{limit} s: threshold {:.3}, false alarms {rate}",
            threshold.log_ratio
        );
        assert!(
            (rate - pfa).abs() < three_se(pfa, trials),
            "{limit} s: {rate}"
        );
    }
}
