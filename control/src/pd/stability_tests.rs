use nalgebra::Complex;

use super::*;
use crate::pd::PdParams;

const ALL_MODELS: [(RateSource, bool); 4] = [
    (RateSource::Measured, false),
    (RateSource::Measured, true),
    (RateSource::BackwardDifference, false),
    (RateSource::BackwardDifference, true),
];

fn joint(inertia: f64, kp: f64, kd: f64, rate: RateSource, delay: bool) -> JointLoop {
    JointLoop {
        inertia_kg_m2: inertia,
        kp_nm_per_rad: kp,
        kd_nm_s_per_rad: kd,
        period_s: 1e-3,
        rate,
        one_cycle_delay: delay,
    }
}

fn inertias(joint: usize) -> impl Iterator<Item = f64> {
    let (lo, hi) = (
        JOINT_INERTIA_MIN_KG_M2[joint],
        JOINT_INERTIA_MAX_KG_M2[joint],
    );
    (0..=24).map(move |i| lo * (hi / lo).powf(f64::from(i) / 24.0))
}

#[test]
fn fine_sampling_recovers_the_continuous_poles() {
    // J s² + kd s + kp = 0, sampled at 100 kHz: z = exp(s T) to high accuracy.
    let (j, kp, kd) = (0.01, 20.0, 0.4);
    let mut model = joint(j, kp, kd, RateSource::Measured, false);
    model.period_s = 1e-5;
    let disc = (kd * kd - 4.0 * j * kp) / (4.0 * j * j);
    let s = Complex::new(-kd / (2.0 * j), 0.0) + Complex::new(disc, 0.0).sqrt();
    let z = (s * model.period_s).exp();
    // The held torque shifts the poles by O(ω T) relative: compare s = ln z / T.
    let poles = model.poles();
    let nearest = poles
        .iter()
        .filter(|p| p.norm() > 1e-9)
        .map(|p| {
            let sp = p.ln() / model.period_s;
            (sp - s).norm().min((sp - s.conj()).norm()) / s.norm()
        })
        .fold(f64::INFINITY, f64::min);
    assert!(nearest < 2e-3, "{poles:?} vs {z}: relative error {nearest}");
    let zeta = kd / (2.0 * (kp * j).sqrt());
    assert!((model.min_damping_ratio() - zeta).abs() < 1e-3);
}

#[test]
fn no_delay_measured_rate_matches_its_characteristic_polynomial() {
    // z² − (2 − b_v kd − b_q kp) z + (1 − b_v kd + b_q kp), b_q = T²/2J, b_v = T/J.
    let (j, kp, kd, t) = (2e-3, 25.0, 0.5, 1e-3);
    let (bq, bv) = (t * t / (2.0 * j), t / j);
    let trace = 2.0 - bv * kd - bq * kp;
    let det = 1.0 - bv * kd + bq * kp;
    let poles = joint(j, kp, kd, RateSource::Measured, false).poles();
    let mut live: Vec<_> = poles.iter().filter(|p| p.norm() > 1e-12).collect();
    live.sort_by(|a, b| a.re.total_cmp(&b.re));
    assert_eq!(live.len(), 2, "{poles:?}");
    assert!(((live[0] + live[1]).re - trace).abs() < 1e-12);
    assert!(((live[0] * live[1]).re - det).abs() < 1e-12);
}

#[test]
fn too_much_damping_for_a_light_joint_is_caught() {
    // kd T / J = 2.5 > 2: the D term alone overshoots every sample.
    assert!(joint(1e-3, 20.0, 2.5, RateSource::Measured, false).spectral_radius() > 1.0);
    // One cycle of delay halves the D term's room: kd T / J = 1.2 is already unstable.
    assert!(joint(1e-3, 20.0, 1.2, RateSource::BackwardDifference, true).spectral_radius() > 1.0);
    // Negative stiffness diverges however it is sampled.
    assert!(joint(1e-2, -5.0, 0.4, RateSource::Measured, false).spectral_radius() > 1.0);
}

#[test]
fn default_gains_are_stable_and_damped_over_the_inertia_range() {
    let p = PdParams::default();
    for j in 0..3 {
        let (kp, kd) = (p.kp_nm_per_rad[j], p.kd_nm_s_per_rad[j]);
        for inertia in inertias(j) {
            for (rate, delay) in ALL_MODELS {
                let m = joint(inertia, kp, kd, rate, delay);
                let rho = m.spectral_radius();
                let zeta = m.min_damping_ratio();
                assert!(
                    rho < 1.0,
                    "joint {j} J {inertia:.1e} {rate:?} delay {delay}: ρ {rho}"
                );
                assert!(
                    zeta > 0.15,
                    "joint {j} J {inertia:.1e} {rate:?} delay {delay}: ζ {zeta}"
                );
            }
            // Gain margin: still stable with the D and P gains doubled, worst model.
            let doubled = joint(
                inertia,
                2.0 * kp,
                2.0 * kd,
                RateSource::BackwardDifference,
                true,
            );
            assert!(
                doubled.spectral_radius() < 1.0,
                "joint {j} J {inertia:.1e} doubled"
            );
        }
    }
}
