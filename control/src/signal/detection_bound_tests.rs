//! The bound against Monte Carlo runs of the ideal detector on raw synthetic samples.

use super::*;
use crate::test_normals::Normals;

const PITCH: f64 = 0.002;

/// A bell-shaped kernel (N per Pa) for the artery at offsets -9..9 mm in 0.5 mm steps.
fn table() -> Vec<(f64, [f64; ELEMENTS])> {
    (-18..=18)
        .map(|k| {
            let x = k as f64 * 0.0005;
            let s = std::array::from_fn(|e| {
                let z = (e as f64 - 4.5) * PITCH;
                1e-6 * (-(z - x).powi(2) / (2.0 * 0.003f64.powi(2))).exp()
            });
            (x, s)
        })
        .collect()
}

/// One beat of pulse pressure, Pa: a systolic bump over 40 samples.
fn waveform(amplitude_pa: f64) -> Vec<f64> {
    (0..40)
        .map(|i| {
            let t = i as f64 / 40.0;
            amplitude_pa * (std::f64::consts::PI * t).sin().powi(3)
        })
        .collect()
}

/// The detectors' statistics on `beats` beats of raw samples with the artery at row `at`
/// (pulse scaled by `scale`; 0 for noise only): (known position's, largest over positions).
fn statistics(
    tab: &[(f64, [f64; ELEMENTS])],
    at: usize,
    w: &[f64],
    scale: f64,
    sigma: f64,
    beats: usize,
    rng: &mut Normals,
) -> (f64, f64) {
    let mean = w.iter().sum::<f64>() / w.len() as f64;
    let wc: Vec<f64> = w.iter().map(|v| v - mean).collect();
    let wn = wc.iter().map(|v| v * v).sum::<f64>().sqrt();
    // Each element's samples, each beat's mean removed (the static load is unknown),
    // filtered with the waveform: a unit normal per element under noise only.
    let mut z = [0.0; ELEMENTS];
    for _ in 0..beats {
        for (e, ze) in z.iter_mut().enumerate() {
            let y: Vec<f64> = w
                .iter()
                .map(|p| scale * tab[at].1[e] * p + sigma * rng.next())
                .collect();
            let ym = y.iter().sum::<f64>() / y.len() as f64;
            *ze += y.iter().zip(&wc).map(|(a, b)| (a - ym) * b).sum::<f64>();
        }
    }
    let norm = sigma * wn * (beats as f64).sqrt();
    let z: [f64; ELEMENTS] = std::array::from_fn(|e| z[e] / norm);
    let project = |s: &[f64; ELEMENTS]| {
        let n = s.iter().map(|v| v * v).sum::<f64>().sqrt();
        s.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>() / n
    };
    let best = tab
        .iter()
        .map(|(_, s)| project(s))
        .fold(f64::NEG_INFINITY, f64::max);
    (project(&tab[at].1), best)
}

/// The searched detector's threshold from 20 000 noise-only draws.
fn searched_threshold(tab: &[(f64, [f64; ELEMENTS])], pfa: f64, rng: &mut Normals) -> f64 {
    glrt_threshold(tab, pfa, 20_000, &mut || rng.next()).expect("threshold")
}

/// Three binomial standard errors of a rate `p` over `n` trials.
fn three_se(p: f64, n: usize) -> f64 {
    3.0 * (p * (1.0 - p) / n as f64).sqrt()
}

#[test]
fn the_normal_quantile_matches_tabulated_values() {
    for (p, q) in [
        (0.5, 0.0),
        (0.975, 1.959_963_985),
        (0.9, 1.281_551_566),
        (1e-6, -4.753_424_309),
        (0.999_9, 3.719_016_485),
    ] {
        assert!(
            (normal_quantile(p) - q).abs() < 1e-7,
            "{p}: {}",
            normal_quantile(p)
        );
    }
    assert_eq!(normal_quantile(0.0), f64::NEG_INFINITY);
    assert_eq!(normal_quantile(1.0), f64::INFINITY);
}

#[test]
fn the_chi_square_quantile_matches_tabulated_values() {
    // 99.9 % points: 13.816 (2), 16.266 (3), 22.458 (6), 24.322 (7); 99 %: 16.812 (6).
    for (p, dof, q) in [
        (0.999, 2.0, 13.816),
        (0.999, 3.0, 16.266),
        (0.999, 6.0, 22.458),
        (0.999, 7.0, 24.322),
        (0.99, 6.0, 16.812),
    ] {
        let got = chi2_quantile(p, dof);
        assert!(
            (got - q).abs() < 0.05 * q,
            "{p}, dof {dof}: {got} against {q}"
        );
    }
}

#[test]
fn the_known_position_bound_agrees_with_its_monte_carlo() {
    let tab = table();
    let at = 18; // under the array's middle
    let (sigma, w) = (0.012, waveform(2000.0));
    let beat = per_beat(&tab, at, waveform_energy(&w), sigma).expect("signal");
    let (pfa, pd) = (0.05, 0.9);
    let eta = known_position_threshold(pfa).expect("pfa");
    let beats = beats_for(snr_needed(eta, pd).expect("pd"), beat.snr);
    assert!(beats > 4.0, "a weak pulse needs several beats: {beats}");
    // Scale the pulse so that a whole number of beats reaches exactly the needed SNR.
    let n = beats.ceil() as usize;
    let scale = (beats / n as f64).sqrt();
    let mut rng = Normals::new(7);
    let trials = 1500;
    let (mut hits, mut alarms) = (0, 0);
    for _ in 0..trials {
        hits += usize::from(statistics(&tab, at, &w, scale, sigma, n, &mut rng).0 > eta);
        alarms += usize::from(statistics(&tab, at, &w, 0.0, sigma, n, &mut rng).0 > eta);
    }
    let (rd, rf) = (hits as f64 / trials as f64, alarms as f64 / trials as f64);
    assert!((rd - pd).abs() < three_se(pd, trials), "detected {rd}");
    assert!(
        (rf - pfa).abs() < three_se(pfa, trials),
        "false alarms {rf}"
    );
}

#[test]
fn the_unknown_position_threshold_holds_its_false_alarm_rate_at_every_length() {
    let tab = table();
    let w = waveform(2000.0);
    let pfa = 0.05;
    let mut rng = Normals::new(11);
    let eta = searched_threshold(&tab, pfa, &mut rng);
    // Above the known-position threshold (a maximum over positions), below Bonferroni's.
    assert!(eta > known_position_threshold(pfa).expect("pfa"));
    assert!(eta < normal_quantile(1.0 - pfa / tab.len() as f64));
    let trials = 1500;
    for beats in [1, 3, 9] {
        let alarms = (0..trials)
            .filter(|_| statistics(&tab, 18, &w, 0.0, 0.012, beats, &mut rng).1 > eta)
            .count();
        let rate = alarms as f64 / trials as f64;
        assert!(
            (rate - pfa).abs() < three_se(pfa, trials),
            "{beats} beats: {rate}"
        );
    }
}

#[test]
fn a_pulse_at_the_bound_is_found_by_the_unknown_position_detector() {
    let tab = table();
    let (sigma, w) = (0.012, waveform(2000.0));
    let (pfa, pd) = (0.05, 0.9);
    let mut rng = Normals::new(13);
    let eta = searched_threshold(&tab, pfa, &mut rng);
    let at = 12; // 3 mm off the middle
    let beat = per_beat(&tab, at, waveform_energy(&w), sigma).expect("signal");
    let beats = beats_for(snr_needed(eta, pd).expect("pd"), beat.snr);
    let n = beats.ceil() as usize;
    let scale = (beats / n as f64).sqrt();
    let trials = 1500;
    let hits = (0..trials)
        .filter(|_| statistics(&tab, at, &w, scale, sigma, n, &mut rng).1 > eta)
        .count();
    let rate = hits as f64 / trials as f64;
    // At least the bound's rate (the maximum only adds), and not far above it: the bound
    // is close where the pulse is just strong enough.
    assert!(rate > pd - three_se(pd, trials), "{rate}");
    assert!(rate < 0.97, "{rate}");
}

#[test]
fn the_position_bound_matches_the_spread_of_the_best_fit() {
    // A fine table, 10 µm steps from -12 to 9 mm: the fit's grid, and the derivative.
    let fine: Vec<(f64, [f64; ELEMENTS])> = (-1200..=900)
        .map(|k| {
            let x = k as f64 * 0.000_01;
            let s = std::array::from_fn(|e| {
                let z = (e as f64 - 4.5) * PITCH;
                1e-6 * (-(z - x).powi(2) / (2.0 * 0.003f64.powi(2))).exp()
            });
            (x, s)
        })
        .collect();
    // At -8.5 mm, past the last element's centre: the kernel runs off the array, so the
    // amplitude and the position trade off (the bound is 20 % wider than with the
    // amplitude known), and the test fails if that term is wrong.
    let at = 350;
    let (sigma, w) = (0.012, waveform(2000.0));
    let beat = per_beat(&fine, at, waveform_energy(&w), sigma).expect("signal");
    // Strong enough (SNR 30) that the best fit is unbiased and efficient.
    let beats = beats_for(30.0, beat.snr).ceil() as usize;
    let crb = (1.0 / (beat.position_information_per_m2 * beats as f64)).sqrt();
    let mut rng = Normals::new(17);
    let c = (waveform_energy(&w) * beats as f64).sqrt() / sigma;
    let trials = 600;
    let mut sq = 0.0;
    for _ in 0..trials {
        let z: [f64; ELEMENTS] = std::array::from_fn(|e| fine[at].1[e] * c + rng.next());
        // Least squares with the amplitude free: the largest projection on the unit kernel.
        let best = fine
            .iter()
            .map(|(x, s)| {
                let n2 = s.iter().map(|v| v * v).sum::<f64>();
                let p = s.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>();
                (p * p / n2, *x)
            })
            .fold(
                (f64::NEG_INFINITY, 0.0),
                |a, b| if b.0 > a.0 { b } else { a },
            );
        sq += (best.1 - fine[at].0).powi(2);
    }
    let spread = (sq / trials as f64).sqrt();
    assert!(
        (spread / crb - 1.0).abs() < 0.12,
        "spread {spread}, bound {crb}"
    );
}

#[test]
fn degenerate_inputs_are_refused_or_give_no_information() {
    let tab = table();
    let w = waveform(2000.0);
    assert!(matches!(
        per_beat(&tab, 18, waveform_energy(&w), 0.0),
        Err(BoundError::Bad { .. })
    ));
    // A flat waveform carries nothing once its mean is removed.
    assert!(matches!(
        per_beat(&tab, 18, waveform_energy(&[5.0; 40]), 0.01),
        Err(BoundError::Bad { .. })
    ));
    let zero = vec![
        (0.0, [0.0; ELEMENTS]),
        (0.001, [0.0; ELEMENTS]),
        (0.002, [0.0; ELEMENTS]),
    ];
    assert_eq!(per_beat(&zero, 1, 1.0, 0.01), Err(BoundError::NoSignal));
    let unordered = vec![
        (0.0, [1.0; ELEMENTS]),
        (0.0, [1.0; ELEMENTS]),
        (0.001, [1.0; ELEMENTS]),
    ];
    assert_eq!(
        per_beat(&unordered, 1, 1.0, 0.01),
        Err(BoundError::Table(3))
    );
    // A kernel that does not change with position says nothing of where the artery is.
    let flat: Vec<_> = (0..5)
        .map(|k| (k as f64 * 0.001, [1e-6; ELEMENTS]))
        .collect();
    let b = per_beat(&flat, 2, 1.0, 0.01).expect("signal");
    assert!(b.snr > 0.0 && b.position_information_per_m2 == 0.0);
    let mut rng = Normals::new(1);
    assert!(glrt_threshold(&tab, 1e-4, 1000, &mut || rng.next()).is_err());
    assert!(known_position_threshold(1.5).is_err() && snr_needed(1.0, 1.0).is_err());
}
