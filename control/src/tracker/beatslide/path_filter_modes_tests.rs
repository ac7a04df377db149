//! The path model's two curvature walks: the mode weights' arithmetic at its edges, and the
//! mixture's point, that it extrapolates like the calm walk on a steady course and follows
//! like the turning walk where the curvature reverses.

use super::*;

fn settings(calm: f64, turning: f64) -> PathFilterSettings {
    PathFilterSettings {
        offset_prior_m: 0.002,
        slope_prior: 0.5,
        curvature_prior_per_m: 1.0 / 0.06,
        curvature_walk: calm,
        turning_walk: turning,
        turn_onset: 0.05,
        turn_end: 0.3,
        lag_prior_m: 0.0,
        lag_prior_sd_m: 1e-6,
        lag_walk: 1e-6,
        gate_sigma: 4.0,
        gate_min_m: 0.002,
    }
}

fn obs(point: SurfacePoint) -> Observation {
    Observation {
        point,
        sd_m: 0.0001,
        lag_dir: [0.0, 0.0],
    }
}

/// A course along +x that runs straight for `straight` m, then as a sinusoid of amplitude
/// 6 mm and wavelength 60 mm (crest radius about 15 mm: reversals every 30 mm).
fn course(straight: f64) -> impl Fn(f64) -> SurfacePoint {
    move |s: f64| {
        let u = (s - straight).max(0.0);
        let k = std::f64::consts::TAU / 0.06;
        SurfacePoint::new(s, 0.006 * (1.0 - (k * u).cos()))
    }
}

/// Follows `at` by fixes 5 mm apart from 0 to `to`; returns the filter, the largest
/// one-step prediction error and the largest turning probability at or after `from`.
fn follow(
    at: &impl Fn(f64) -> SurfacePoint,
    s: PathFilterSettings,
    from: f64,
    to: f64,
) -> (PathFilter, f64, f64) {
    let step = 0.005;
    let mut f =
        PathFilter::from_observations(&[obs(at(0.0)), obs(at(step))], 0.0, s).expect("two points");
    let (mut worst, mut turning): (f64, f64) = (0.0, 0.0);
    let mut k = 2;
    while k as f64 * step <= to + 1e-12 {
        let x = k as f64 * step;
        let (along, _) = f.to_local(at(x));
        let predicted = f.predict(along).point;
        if x >= from {
            worst = worst.max((predicted.z_m - at(x).z_m).abs());
        }
        f.update(&obs(at(x))).expect("inside the gate");
        if x >= from {
            turning = turning.max(f.turning_probability());
        }
        k += 1;
    }
    (f, worst, turning)
}

#[test]
fn the_mode_weights_are_bayes_and_never_nan() {
    let prior = [0.7, 0.3];
    // Equal variances: the innovation says nothing, the prior stands.
    let same = path_modes::posterior(prior, [0.003, 0.003], [1e-6, 1e-6]);
    assert!((same[0] - 0.7).abs() < 1e-12 && (same[1] - 0.3).abs() < 1e-12);
    // Against a direct evaluation of the two Gaussians.
    let (v0, v1, nu) = (1.0e-6, 4.0e-6, 1.5e-3);
    let g = |v: f64| (-0.5 * nu * nu / v).exp() / v.sqrt();
    let want = prior[1] * g(v1) / (prior[0] * g(v0) + prior[1] * g(v1));
    let got = path_modes::posterior(prior, [nu, nu], [v0, v1]);
    assert!((got[1] - want).abs() < 1e-12, "{got:?} vs {want}");
    assert!((got[0] + got[1] - 1.0).abs() < 1e-12);
    // A zero innovation favours the narrow mode, a large one the wide.
    assert!(path_modes::posterior(prior, [0.0, 0.0], [v0, v1])[1] < prior[1]);
    assert!(path_modes::posterior(prior, [3e-3, 3e-3], [v0, v1])[1] > prior[1]);
    // An innovation far beyond both (each likelihood underflows alone) still gives weights.
    let far = path_modes::posterior(prior, [1.0, 1.0], [v0, v1]);
    assert!(far.iter().all(|w| w.is_finite()), "{far:?}");
    assert!(far[1] > 0.999_999, "{far:?}");
    // A mode the prior rules out stays out.
    let ruled_out = path_modes::posterior([1.0, 0.0], [3e-3, 3e-3], [v0, v1]);
    assert!(ruled_out[1] < 1e-100, "{ruled_out:?}");
}

#[test]
fn a_turning_walk_not_above_the_calm_one_is_one_filter() {
    let at = course(0.05);
    let (one, ..) = follow(&at, settings(45.0, 45.0), 0.0, 0.15);
    let (below, ..) = follow(&at, settings(45.0, 10.0), 0.0, 0.15);
    assert_eq!(one.x, below.x);
    assert_eq!(one.p, below.p);
    assert_eq!(one.turning_probability(), TURNING_PRIOR);
    assert_eq!(one.modes[0], one.modes[1]);
}

#[test]
fn the_modes_tell_a_steady_course_from_a_reversing_one() {
    let (calm, turning) = (10.0, 400.0);
    let at = course(0.1);
    // The straight run: the calm mode takes over, and the prediction 25 mm ahead is far
    // surer than the turning walk's. (Not as sure as the calm walk's alone: the turning
    // mode keeps at least its onset's weight, and its spread dominates the mixture's.)
    let (mixed, ..) = follow(&at, settings(calm, turning), 0.0, 0.095);
    assert!(
        mixed.turning_probability() < 0.2,
        "{}",
        mixed.turning_probability()
    );
    let sd_mixed = mixed.predict(0.025).sd_m;
    let (calm_only, ..) = follow(&at, settings(calm, calm), 0.0, 0.095);
    let (turning_only, ..) = follow(&at, settings(turning, turning), 0.0, 0.095);
    let (sd_calm, sd_turning) = (
        calm_only.predict(0.025).sd_m,
        turning_only.predict(0.025).sd_m,
    );
    assert!(
        sd_mixed > sd_calm && sd_mixed < 0.5 * sd_turning,
        "{sd_mixed} against {sd_calm} (calm) and {sd_turning} (turning)"
    );
    // Then the reversals: the turning mode takes over, and the one-step predictions stay
    // near the turning walk's, well inside the calm walk's.
    let (_, worst_mixed, turning_mixed) = follow(&at, settings(calm, turning), 0.1, 0.2);
    let (_, worst_calm, _) = follow(&at, settings(calm, calm), 0.1, 0.2);
    let (_, worst_turning, _) = follow(&at, settings(turning, turning), 0.1, 0.2);
    assert!(turning_mixed > 0.5, "{turning_mixed}");
    assert!(
        worst_mixed < 0.6 * worst_calm && worst_mixed < 1.5 * worst_turning,
        "{worst_mixed} against {worst_calm} (calm) and {worst_turning} (turning)"
    );
}
