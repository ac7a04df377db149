use proptest::prelude::*;

use super::*;
use crate::kinematics::pivot::rod_pose;
use crate::test_normals::Normals;

/// A unit direction `tilt` from straight down toward azimuth `azimuth`.
fn down_cone(tilt: f64, azimuth: f64) -> Vector3<f64> {
    Vector3::new(
        tilt.sin() * azimuth.cos(),
        -tilt.cos(),
        tilt.sin() * azimuth.sin(),
    )
}

/// Rods through `pivot` at the given directions, each given by its gimbal point (the rod
/// length above the tip at `depth`), as the arm's forward kinematics would place it.
fn rods_through(pivot: Point3<f64>, directions: &[Vector3<f64>], depth: f64) -> Vec<RodLine> {
    let geometry = PivotGeometry {
        pivot_in_base_m: [pivot.x, pivot.y, pivot.z],
        ..PivotGeometry::default()
    };
    directions
        .iter()
        .map(|u| {
            let gimbal = Gimbal(pivot - (geometry.rod_length_m - depth) * u);
            let pose = rod_pose(&geometry, &gimbal).unwrap();
            RodLine::through(&gimbal, &pose.tip)
        })
        .collect()
}

fn cone(count: usize, tilt: f64) -> Vec<Vector3<f64>> {
    (0..count)
        .map(|i| down_cone(tilt, std::f64::consts::TAU * i as f64 / count as f64))
        .collect()
}

#[test]
fn noise_free_rods_give_the_pivot_exactly() {
    let pivot = Point3::new(0.004, -0.087, 0.051);
    let mut dirs = cone(8, 0.25);
    dirs.push(down_cone(0.0, 0.0));
    let fit = fit_pivot(&rods_through(pivot, &dirs, 0.28)).unwrap();
    assert!((fit.pivot.0 - pivot).norm() < 1e-12, "{fit:?}");
    assert!(fit.rms_residual_m < 1e-12 && fit.max_residual_m < 1e-12);
    assert!(fit.standard_error_m < 1e-11);
    assert_eq!(fit.lines, 9);
    // Eight rods 0.25 rad from the axis and one on it: mean sin² = 8 sin²(0.25)/9.
    let expected = ((8.0 / 9.0) * 0.25f64.sin().powi(2)).sqrt().asin();
    assert!(
        (fit.spread_rad - expected).abs() < 1e-12,
        "{}",
        fit.spread_rad
    );
    assert!(fit.checks(&Tolerances::default()).iter().all(Check::passed));
    // Rods along the three axes: λmin/n = 2/3, the widest spread there is.
    let axes = [Vector3::x(), Vector3::y(), Vector3::z()];
    let widest = fit_pivot(&rods_through(pivot, &axes, 0.28)).unwrap();
    assert!((widest.spread_rad - (2.0f64 / 3.0).sqrt().asin()).abs() < 1e-12);
    assert!((widest.condition_number - 1.0).abs() < 1e-12);
    let geometry = fit.apply_to(&PivotGeometry::default());
    assert_eq!(
        geometry.pivot_in_base_m,
        [fit.pivot.0.x, fit.pivot.0.y, fit.pivot.0.z]
    );
    assert_eq!(geometry.rod_length_m, PivotGeometry::default().rod_length_m);
}

#[test]
fn two_crossing_rods_meet_at_the_pivot_and_the_spread_is_half_their_angle() {
    let pivot = Point3::new(0.0, -0.09, 0.055);
    let dirs = [down_cone(0.2, 0.0), down_cone(0.2, std::f64::consts::PI)];
    let fit = fit_pivot(&rods_through(pivot, &dirs, 0.2)).unwrap();
    assert!((fit.pivot.0 - pivot).norm() < 1e-12);
    assert!((fit.spread_rad - 0.2).abs() < 1e-12);
    // Eigenvalues 2 and 1 ± cos 0.4 (the angle between the rods).
    assert!((fit.min_eigenvalue - (1.0 - 0.4f64.cos())).abs() < 1e-12);
    assert!((fit.condition_number - 2.0 / (1.0 - 0.4f64.cos())).abs() < 1e-6);
    // Two lines that meet: σ from one degree of freedom is zero.
    assert!(fit.standard_error_m < 1e-10);
}

#[test]
fn skew_rods_give_the_midpoint_of_their_common_perpendicular() {
    // x axis at y = 0 and z axis at y = 0.002: the closest point is (0, 0.001, 0), 1 mm from each.
    let lines = [
        RodLine::new(Point3::new(5.0, 0.0, 0.0), Vector3::x()),
        RodLine::new(Point3::new(0.0, 0.002, -3.0), Vector3::z() * 1e-6),
    ];
    let fit = fit_pivot(&lines).unwrap();
    assert!((fit.pivot.0 - Point3::new(0.0, 0.001, 0.0)).norm() < 1e-12);
    assert!((fit.rms_residual_m - 0.001).abs() < 1e-12);
    assert!((fit.max_residual_m - 0.001).abs() < 1e-12);
    assert!(!fit.checks(&Tolerances::default())[0].passed());
}

#[test]
fn noisy_rods_give_a_residual_of_the_noise_and_an_honest_standard_error() {
    // Each rod displaced sideways by normal noise of SD 0.2 mm per axis across it: the
    // expected squared distance is 2σ² less the three the fit absorbs.
    let sigma = 0.2e-3;
    let pivot = Point3::new(0.01, -0.09, 0.05);
    let mut normals = Normals::new(7);
    let mut errors = Vec::new();
    let mut ratios = Vec::new();
    for trial in 0..200 {
        let count = 40;
        let dirs: Vec<_> = (0..count)
            .map(|i| {
                let tilt = 0.1 + 0.2 * normals.uniform();
                down_cone(
                    tilt,
                    std::f64::consts::TAU * (i as f64 + normals.uniform()) / 40.0,
                )
            })
            .collect();
        let lines: Vec<_> = rods_through(pivot, &dirs, 0.25)
            .into_iter()
            .map(|l| {
                let u = l.direction.normalize();
                let e1 = u.cross(&Vector3::x()).normalize();
                let e2 = u.cross(&e1);
                let shift = sigma * (normals.next() * e1 + normals.next() * e2);
                RodLine::new(l.point + shift, l.direction)
            })
            .collect();
        let fit = fit_pivot(&lines).unwrap();
        let expected = sigma * (2.0 * (1.0 - 3.0 / (2.0 * count as f64))).sqrt();
        let r = fit.rms_residual_m / expected;
        assert!(
            (0.75..1.25).contains(&r),
            "trial {trial}: residual ratio {r}"
        );
        ratios.push(r);
        errors.push((fit.pivot.0 - pivot).norm() / fit.standard_error_m);
    }
    let mean_ratio = ratios.iter().sum::<f64>() / ratios.len() as f64;
    assert!(
        (mean_ratio - 1.0).abs() < 0.02,
        "mean residual ratio {mean_ratio}"
    );
    // The error in units of the worst-direction standard error: never far beyond it.
    let worst = errors.iter().cloned().fold(0.0, f64::max);
    assert!(worst < 4.0, "pivot error {worst} standard errors");
    let within = errors.iter().filter(|e| **e < 1.0).count();
    assert!(
        within > 100,
        "only {within} of 200 within one standard error"
    );
}

#[test]
fn parallel_rods_are_refused_naming_why() {
    let lines = [
        RodLine::new(Point3::new(0.0, 0.0, 0.0), Vector3::new(0.0, -1.0, 0.0)),
        RodLine::new(Point3::new(0.01, 0.3, 0.0), Vector3::new(0.0, -2.0, 0.0)),
        RodLine::new(Point3::new(0.0, 0.1, 0.02), Vector3::new(0.0, 3.0, 0.0)),
    ];
    let e = fit_pivot(&lines).unwrap_err();
    assert!(
        matches!(e, PivotFitError::Parallel { spread_rad, .. } if spread_rad < 1e-12),
        "{e:?}"
    );
    assert!(e.to_string().contains("parallel"), "{e}");
    // Just under the refusal: still refused. Just over: fitted.
    let near = |angle: f64| {
        [
            RodLine::new(Point3::origin(), down_cone(angle, 0.0)),
            RodLine::new(Point3::origin(), down_cone(angle, std::f64::consts::PI)),
        ]
    };
    assert!(matches!(
        fit_pivot(&near(0.9 * PARALLEL_SPREAD_RAD)),
        Err(PivotFitError::Parallel { .. })
    ));
    let fit = fit_pivot(&near(1.1 * PARALLEL_SPREAD_RAD)).unwrap();
    assert!(fit.pivot.0.coords.norm() < 1e-9, "{fit:?}");
}

#[test]
fn nearly_parallel_rods_are_fitted_but_flagged_ill_conditioned() {
    // A 2° cone: the pivot is found, but the spread fails the default 0.1 rad and the
    // standard error along the rods is many times the noise across them.
    let pivot = Point3::new(0.0, -0.09, 0.055);
    let mut normals = Normals::new(3);
    let lines: Vec<_> = rods_through(pivot, &cone(12, 0.035), 0.28)
        .into_iter()
        .map(|l| {
            let shift = 0.1e-3 * Vector3::new(normals.next(), 0.0, normals.next());
            RodLine::new(l.point + shift, l.direction)
        })
        .collect();
    let fit = fit_pivot(&lines).unwrap();
    let [residual, spread] = fit.checks(&Tolerances::default());
    assert!(residual.passed(), "{residual}");
    assert!(!spread.passed(), "{spread}");
    assert!((fit.spread_rad - 0.035).abs() < 1e-3);
    assert!(fit.condition_number > 500.0, "{}", fit.condition_number);
    assert!(fit.standard_error_m > 5.0 * fit.rms_residual_m, "{fit:?}");
}

#[test]
fn too_few_or_bad_lines_are_refused_naming_the_line() {
    let good = RodLine::new(Point3::origin(), Vector3::y());
    assert_eq!(fit_pivot(&[]), Err(PivotFitError::TooFewLines { lines: 0 }));
    assert_eq!(
        fit_pivot(&[good]),
        Err(PivotFitError::TooFewLines { lines: 1 })
    );
    let other = RodLine::new(Point3::new(1.0, 0.0, 0.0), Vector3::x());
    let nan_point = RodLine::new(Point3::new(0.0, f64::NAN, 0.0), Vector3::x());
    let inf_dir = RodLine::new(Point3::origin(), Vector3::new(f64::INFINITY, 0.0, 0.0));
    let zero_dir = RodLine::new(Point3::origin(), Vector3::zeros());
    assert_eq!(
        fit_pivot(&[good, other, nan_point]),
        Err(PivotFitError::NonFinite {
            line: 2,
            what: "point"
        })
    );
    let e = fit_pivot(&[good, inf_dir, other]).unwrap_err();
    assert_eq!(
        e,
        PivotFitError::NonFinite {
            line: 1,
            what: "direction"
        }
    );
    assert_eq!(e.to_string(), "rod line 1: its direction is not finite");
    assert!(matches!(
        fit_pivot(&[zero_dir, good, other]),
        Err(PivotFitError::ZeroDirection { line: 0 })
    ));
    // A tiny but real direction is a direction.
    let tiny = RodLine::new(Point3::new(0.0, 0.0, 1.0), Vector3::x() * 1e-300);
    let fit = fit_pivot(&[good, tiny]).unwrap();
    assert!(
        (fit.pivot.0 - Point3::new(0.0, 0.0, 0.5)).norm() < 1e-12,
        "{fit:?}"
    );
}

#[test]
fn coordinates_too_large_for_the_fit_are_refused_not_answered_with_nan() {
    let lines = [
        RodLine::new(Point3::new(1e308, 0.0, 0.0), Vector3::y()),
        RodLine::new(Point3::new(1.5e308, 0.0, 0.0), Vector3::z()),
    ];
    assert_eq!(fit_pivot(&lines), Err(PivotFitError::Overflow));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn a_random_pivot_is_recovered_from_random_rods(
        px in -0.3..0.3f64, py in -0.4..0.1f64, pz in -0.3..0.3f64,
        dirs in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64), 2..12),
        along in prop::collection::vec(-0.5..0.5f64, 12),
    ) {
        let pivot = Point3::new(px, py, pz);
        let units: Vec<Vector3<f64>> = dirs
            .iter()
            .map(|&(x, y, z)| Vector3::new(x, y, z))
            .filter(|v| v.norm() > 0.1)
            .map(|v| v.normalize())
            .collect();
        prop_assume!(units.len() >= 2);
        let lines: Vec<_> = units
            .iter()
            .zip(&along)
            .map(|(u, t)| RodLine::new(pivot + u * *t, u * (1.0 + t.abs())))
            .collect();
        let fit = fit_pivot(&lines);
        prop_assert!(fit.is_ok(), "refused {:?}", fit);
        let fit = fit.unwrap();
        // Rods within 0.05 rad of one axis are not the non-degenerate case this checks.
        prop_assume!(fit.spread_rad > 0.05);
        prop_assert!((fit.pivot.0 - pivot).norm() < 1e-9, "{:?}", fit);
        prop_assert!(fit.rms_residual_m < 1e-9);
    }
}
