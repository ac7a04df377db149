use proptest::prelude::*;

use super::*;
use crate::kinematics::{JointLimits, PhantomGeometry, PivotGeometry, pivot};
use crate::test_normals::Normals;

fn placement(origin: [f64; 3], yaw_rad: f64) -> TissuePlacement {
    TissuePlacement {
        origin_in_base_m: origin,
        yaw_rad,
    }
}

/// Tissue-frame surface points (x, z) of `truth`, in the base frame.
fn touches(truth: &TissuePlacement, xz: &[(f64, f64)]) -> Vec<Point3<f64>> {
    xz.iter()
        .map(|&(x, z)| truth.to_base(&Point3::new(x, 0.0, z)))
        .collect()
}

fn artery_of(truth: &TissuePlacement, x_from: f64, x_to: f64) -> ArteryCourse {
    ArteryCourse {
        from: truth.to_base(&Point3::new(x_from, 0.0, 0.0)),
        to: truth.to_base(&Point3::new(x_to, 0.0, 0.0)),
        lateral_m: 0.0,
    }
}

#[test]
fn a_course_off_the_frames_axis_keeps_the_origin_where_it_truly_is() {
    // The course 27.2 mm to +z of tissue x (the shipped arcs' chord), yawed 5 degrees, the
    // surface 2 mm higher than configured; the origin's horizontal position is right.
    let configured = placement([0.0, -0.3745, 0.055], 0.0);
    let truth = placement([0.0, -0.3725, 0.055], 5f64.to_radians());
    let lateral = 0.0272;
    let course = ArteryCourse {
        from: truth.to_base(&Point3::new(-0.113, 0.0, lateral)),
        to: truth.to_base(&Point3::new(0.113, 0.0, lateral)),
        lateral_m: lateral,
    };
    let fit = fit_tissue_frame(&touches(&truth, &PATCH), Some(&course), &configured).unwrap();
    for i in 0..3 {
        let d = fit.placement.origin_in_base_m[i] - truth.origin_in_base_m[i];
        assert!(d.abs() < 1e-12, "origin {i} off by {d} m: {fit:?}");
    }
    assert!((fit.placement.yaw_rad - truth.yaw_rad).abs() < 1e-12);
    // Taken as on tissue x, the same course would shift the origin across by 27 mm.
    let on_axis = ArteryCourse {
        lateral_m: 0.0,
        ..course
    };
    let wrong = fit_tissue_frame(&touches(&truth, &PATCH), Some(&on_axis), &configured).unwrap();
    let shift = (wrong.placement.origin_in_base_m[2] - truth.origin_in_base_m[2]).abs();
    assert!(
        (shift - lateral * truth.yaw_rad.cos()).abs() < 1e-9,
        "{shift}"
    );
}

const PATCH: [(f64, f64); 5] = [
    (-0.1, -0.05),
    (0.1, -0.05),
    (0.1, 0.05),
    (-0.1, 0.05),
    (0.0, 0.0),
];

fn same_yaw(a: f64, b: f64) -> f64 {
    (a - b).sin().abs().max(((a - b).cos() - 1.0).abs())
}

#[test]
fn a_level_yawed_surface_is_recovered_exactly() {
    let truth = placement([0.012, -0.3745, 0.061], 0.087);
    // The configured placement is yawed 5° and 4 mm high; its origin is where the tissue
    // frame's x = 0 lies along the artery.
    let prior = placement([0.012, -0.3705, 0.061], 0.0);
    let fit = fit_tissue_frame(
        &touches(&truth, &PATCH),
        Some(&artery_of(&truth, -0.08, 0.09)),
        &prior,
    )
    .unwrap();
    assert_eq!(fit.yaw_from, YawSource::ArteryCourse);
    assert!(same_yaw(fit.placement.yaw_rad, truth.yaw_rad) < 1e-12);
    let moved =
        Vector3::from(fit.placement.origin_in_base_m) - Vector3::from(truth.origin_in_base_m);
    assert!(moved.norm() < 1e-12, "{fit:?}");
    assert!(fit.tilt_rad < 1e-9 && fit.rms_residual_m < 1e-12);
    assert!((fit.normal_in_base - Vector3::y()).norm() < 1e-9);
    assert_eq!(fit.points, 5);
    assert!(fit.checks(&Tolerances::default()).iter().all(Check::passed));
}

#[test]
fn without_an_artery_course_the_prior_yaw_and_position_are_kept_and_the_height_fitted() {
    let truth = placement([0.0, -0.3745, 0.055], 0.0);
    let prior = placement([0.003, -0.36, 0.05], 0.2);
    let fit = fit_tissue_frame(&touches(&truth, &PATCH), None, &prior).unwrap();
    assert_eq!(fit.yaw_from, YawSource::Prior);
    assert_eq!(fit.placement.yaw_rad, 0.2);
    let [x, y, z] = fit.placement.origin_in_base_m;
    assert_eq!((x, z), (0.003, 0.05));
    assert!((y + 0.3745).abs() < 1e-12);
}

#[test]
fn the_origin_moves_across_onto_the_artery_but_keeps_its_place_along_it() {
    let truth = placement([0.0, -0.3, 0.0], 0.0);
    // 7 mm along the artery and 3 mm across it from the true origin.
    let prior = placement([0.007, -0.3, 0.003], 0.0);
    let fit = fit_tissue_frame(
        &touches(&truth, &PATCH),
        Some(&artery_of(&truth, 0.05, -0.05)),
        &prior,
    )
    .unwrap();
    // From +x toward −x: the yaw is a half turn.
    assert!(same_yaw(fit.placement.yaw_rad, std::f64::consts::PI) < 1e-12);
    let [x, y, z] = fit.placement.origin_in_base_m;
    assert!((x - 0.007).abs() < 1e-12 && (y + 0.3).abs() < 1e-12 && z.abs() < 1e-12);
}

#[test]
fn a_tilted_surface_gives_its_tilt_and_its_height_under_the_origin_and_fails_the_check() {
    // The plane y = −0.3 + 0.05 x (base): tilt atan(0.05), height at the origin x = 0.02.
    let surface: Vec<_> = PATCH
        .iter()
        .map(|&(x, z)| Point3::new(x, -0.3 + 0.05 * x, z))
        .collect();
    let prior = placement([0.02, -0.3, 0.0], 0.0);
    let fit = fit_tissue_frame(&surface, None, &prior).unwrap();
    assert!(
        (fit.tilt_rad - 0.05f64.atan()).abs() < 1e-12,
        "{}",
        fit.tilt_rad
    );
    assert!((fit.placement.origin_in_base_m[1] - (-0.3 + 0.05 * 0.02)).abs() < 1e-12);
    assert!(fit.normal_in_base.x < 0.0 && fit.normal_in_base.y > 0.0);
    let [residual, tilt] = fit.checks(&Tolerances::default());
    assert!(residual.passed(), "{residual}");
    assert!(!tilt.passed(), "{tilt}");
    // Just inside the default 0.02 rad: passes.
    let surface: Vec<_> = PATCH
        .iter()
        .map(|&(x, z)| Point3::new(x, -0.3 + 0.0199f64.tan() * z, z))
        .collect();
    let fit = fit_tissue_frame(&surface, None, &prior).unwrap();
    assert!(fit.checks(&Tolerances::default())[1].passed(), "{fit:?}");
}

#[test]
fn touch_noise_shows_as_the_residual() {
    let sigma = 0.2e-3;
    let mut normals = Normals::new(11);
    let truth = placement([0.0, -0.3745, 0.055], 0.3);
    let xz: Vec<_> = (0..400)
        .map(|_| {
            (
                0.2 * normals.uniform() - 0.1,
                0.1 * normals.uniform() - 0.05,
            )
        })
        .collect();
    let surface: Vec<_> = touches(&truth, &xz)
        .into_iter()
        .map(|p| p + Vector3::new(0.0, sigma * normals.next(), 0.0))
        .collect();
    let fit = fit_tissue_frame(&surface, None, &truth).unwrap();
    let ratio = fit.rms_residual_m / sigma;
    assert!((0.9..1.1).contains(&ratio), "residual {ratio} σ");
    // 400 points over 0.2 × 0.1 m: the height within a few σ/√n, the slope along the
    // narrower side within a few σ/(√n SD(z)), SD(z) = 0.1/√12 m.
    assert!((fit.placement.origin_in_base_m[1] + 0.3745).abs() < 4.0 * sigma / 20.0);
    let slope_se = sigma / (20.0 * 0.1 / 12f64.sqrt());
    assert!(
        fit.tilt_rad < 4.0 * slope_se,
        "{} vs {slope_se}",
        fit.tilt_rad
    );
    assert!(fit.max_residual_m >= fit.rms_residual_m);
    assert!((surface[fit.worst_point].y + 0.3745).abs() > 2.0 * sigma);
    let tight = Tolerances {
        tissue_max_rms_residual_m: 0.1e-3,
        ..Default::default()
    };
    assert!(!fit.checks(&tight)[0].passed());
}

#[test]
fn degenerate_touches_are_refused_naming_why() {
    let truth = placement([0.0, -0.3, 0.0], 0.0);
    let prior = truth;
    let two = touches(&truth, &PATCH[..2]);
    assert_eq!(
        fit_tissue_frame(&two, None, &prior),
        Err(TissueFrameError::TooFewPoints { points: 2 })
    );
    let mut bad = touches(&truth, &PATCH);
    bad[3].z = f64::NAN;
    let e = fit_tissue_frame(&bad, None, &prior).unwrap_err();
    assert_eq!(e.to_string(), "surface point 3 is not finite");
    // Within half a millimetre of each other.
    let huddle = touches(
        &truth,
        &[(0.0, 0.0), (0.0005, 0.0), (0.0, 0.0005), (0.0003, 0.0003)],
    );
    assert!(matches!(
        fit_tissue_frame(&huddle, None, &prior),
        Err(TissueFrameError::Coincident { .. })
    ));
    // Along a line with 0.1 mm of scatter across it.
    let line = touches(
        &truth,
        &[(-0.05, 0.0), (-0.02, 0.0001), (0.01, -0.0001), (0.05, 0.0)],
    );
    let e = fit_tissue_frame(&line, None, &prior).unwrap_err();
    assert!(
        matches!(e, TissueFrameError::Collinear { width_m, .. } if width_m < 1e-4),
        "{e}"
    );
    // A vertical wall.
    let wall: Vec<_> = PATCH
        .iter()
        .map(|&(x, z)| Point3::new(x, z, 0.01))
        .collect();
    assert!(matches!(
        fit_tissue_frame(&wall, None, &prior),
        Err(TissueFrameError::TooSteep { .. })
    ));
    let good = touches(&truth, &PATCH);
    // Artery points one above the other: no horizontal direction.
    let short = ArteryCourse {
        from: Point3::new(0.0, -0.3, 0.0),
        to: Point3::new(0.005, -0.25, 0.005),
        lateral_m: 0.0,
    };
    assert!(matches!(
        fit_tissue_frame(&good, Some(&short), &prior),
        Err(TissueFrameError::ArteryTooShort { .. })
    ));
    let nan_artery = ArteryCourse {
        from: Point3::new(0.0, -0.3, 0.0),
        to: Point3::new(f64::INFINITY, -0.3, 0.0),
        lateral_m: 0.0,
    };
    assert_eq!(
        fit_tissue_frame(&good, Some(&nan_artery), &prior),
        Err(TissueFrameError::NonFinite {
            what: "artery point",
            index: 1
        })
    );
    let nan_prior = placement([0.0, f64::NAN, 0.0], 0.0);
    assert_eq!(
        fit_tissue_frame(&good, None, &nan_prior),
        Err(TissueFrameError::NonFinitePrior)
    );
}

#[test]
fn touched_points_from_joints_are_the_sensor_centre_in_the_base_frame() {
    let geometry = PivotGeometry::default();
    let model = ArmModel::new(
        PhantomGeometry::default(),
        JointLimits::default(),
        geometry,
        placement([0.0, -0.3745, 0.055], 0.4),
        [0.0, -0.0045, 0.0],
    )
    .unwrap();
    let q = [0.1, 0.5, 0.55];
    let gimbal = crate::kinematics::phantom::forward(model.phantom(), &q).unwrap();
    let tip = pivot::tip_from_gimbal(&geometry, &gimbal).unwrap();
    let p = touched_point_in_base(&model, &q).unwrap();
    assert!((p - (tip.0 + Vector3::new(0.0, -0.0045, 0.0))).norm() < 1e-15);
    assert!(touched_point_in_base(&model, &[f64::NAN, 0.5, 0.5]).is_err());
}

#[test]
fn coordinates_too_large_for_the_fit_are_refused_not_answered_with_nan() {
    let prior = placement([0.0, -0.3, 0.0], 0.0);
    let huge: Vec<_> = PATCH
        .iter()
        .map(|&(x, z)| Point3::new(x * 1e200, -0.3, z * 1e200))
        .collect();
    assert_eq!(
        fit_tissue_frame(&huge, None, &prior),
        Err(TissueFrameError::Overflow)
    );
    let far = ArteryCourse {
        from: Point3::new(-1e308, -0.3, 0.0),
        to: Point3::new(1e308, -0.3, 0.0),
        lateral_m: 0.0,
    };
    assert_eq!(
        fit_tissue_frame(&touches(&prior, &PATCH), Some(&far), &prior),
        Err(TissueFrameError::Overflow)
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn a_random_placement_is_recovered_from_touches_it_generates(
        ox in -0.2..0.2f64, oy in -0.5..-0.1f64, oz in -0.2..0.2f64,
        yaw in -3.1..3.1f64,
        jitter in prop::collection::vec((-0.01..0.01f64, -0.01..0.01f64), 3),
        extra in prop::collection::vec((-0.1..0.1f64, -0.1..0.1f64), 0..6),
        (x_from, x_to) in (-0.1..-0.01f64, 0.01..0.1f64),
        (along, across, up, yaw_error) in (-0.05..0.05f64, -0.01..0.01f64, -0.01..0.01f64, -0.2..0.2f64),
    ) {
        let truth = placement([ox, oy, oz], yaw);
        // A well-spread triangle, moved about, and any further points.
        let mut xz: Vec<(f64, f64)> = [(-0.04, -0.03), (0.04, -0.03), (0.0, 0.04)]
            .iter()
            .zip(&jitter)
            .map(|(&(x, z), &(dx, dz))| (x + dx, z + dz))
            .collect();
        xz.extend(extra);
        let prior = placement(
            truth.to_base(&Point3::new(along, up, across)).coords.into(),
            yaw + yaw_error,
        );
        let fit = fit_tissue_frame(&touches(&truth, &xz), Some(&artery_of(&truth, x_from, x_to)), &prior);
        prop_assert!(fit.is_ok(), "{:?}", fit);
        let fit = fit.unwrap();
        prop_assert!(same_yaw(fit.placement.yaw_rad, yaw) < 1e-9);
        // The true origin moved along the artery to where the prior put x = 0.
        let expected = truth.to_base(&Point3::new(along, 0.0, 0.0));
        let got = Point3::from(fit.placement.origin_in_base_m);
        prop_assert!((got - expected).norm() < 1e-9, "{:?} vs {:?}", got, expected);
        prop_assert!(fit.tilt_rad < 1e-9 && fit.rms_residual_m < 1e-9);
        // And the fitted placement maps every touch to the surface at its own x, z.
        for (p, &(x, z)) in touches(&truth, &xz).iter().zip(&xz) {
            let t = fit.placement.to_tissue(p);
            prop_assert!((t - Point3::new(x - along, 0.0, z)).norm() < 1e-9);
        }
    }
}
