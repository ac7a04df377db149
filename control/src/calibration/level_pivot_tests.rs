use super::*;
use crate::frames::TissuePlacement;
use crate::kinematics::{DEFAULT_SENSOR_OFFSET_M, JointLimits, PhantomGeometry};

fn model(pivot: PivotGeometry) -> ArmModel {
    ArmModel::new(
        PhantomGeometry::default(),
        JointLimits::default(),
        pivot,
        TissuePlacement {
            origin_in_base_m: [0.0, -0.3745, 0.055],
            yaw_rad: 0.0,
        },
        DEFAULT_SENSOR_OFFSET_M,
    )
    .expect("model")
}

/// Touches of a level plate at `height` (tissue frame) over a grid, made by the arm whose
/// pivot is `truth`, as the arm configured with `configured` believes them.
fn touches(
    truth: &ArmModel,
    configured: &ArmModel,
    height: f64,
    grid: &[(f64, f64)],
) -> Vec<Point3<f64>> {
    grid.iter()
        .map(|&(x, z)| {
            let q = truth
                .joints_for_sensor(&Point3::new(x, height, z))
                .expect("reachable");
            configured.sensor_from_joints(&q).expect("believed")
        })
        .collect()
}

const GRID: [(f64, f64); 9] = [
    (-0.06, -0.04),
    (0.0, -0.04),
    (0.06, -0.04),
    (-0.06, 0.0),
    (0.0, 0.0),
    (0.06, 0.0),
    (-0.06, 0.04),
    (0.0, 0.04),
    (0.06, 0.04),
];

#[test]
fn a_pivot_off_to_the_side_is_found_from_touches_on_a_level_plate() {
    let configured = PivotGeometry::default();
    let mut true_pivot = configured;
    true_pivot.pivot_in_base_m[0] += 0.003;
    true_pivot.pivot_in_base_m[2] -= 0.005;
    let (truth, believed) = (model(true_pivot), model(configured));
    let seen = touches(&truth, &believed, -0.001, &GRID);
    // As configured, the level plate reads as tilted: the symptom the fit removes.
    let spread = seen.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max)
        - seen.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    assert!(
        spread > 2e-3,
        "the plate looks level through the wrong pivot: {spread} m"
    );
    let fit = fit_pivot_level(&believed, &seen).expect("fit");
    assert!((fit.offset_m[0] - 0.003).abs() < 1e-6, "{fit:?}");
    assert!((fit.offset_m[1] + 0.005).abs() < 1e-6, "{fit:?}");
    assert!(fit.rms_residual_m < 1e-7, "{fit:?}");
    assert!(
        fit.checks(&Tolerances::default()).iter().all(Check::passed),
        "{fit:?}"
    );
    // The right pivot reads the same touches level.
    let again = fit_pivot_level(&truth, &touches(&truth, &truth, -0.001, &GRID)).expect("fit");
    assert!(
        again.offset_m[0].abs() < 1e-7 && again.offset_m[1].abs() < 1e-7,
        "{again:?}"
    );
}

#[test]
fn touch_noise_shows_in_the_residual_and_the_standard_error() {
    let configured = PivotGeometry::default();
    let mut true_pivot = configured;
    true_pivot.pivot_in_base_m[2] += 0.005;
    let (truth, believed) = (model(true_pivot), model(configured));
    let mut seen = touches(&truth, &believed, -0.001, &GRID);
    // ±0.05 mm on the heights, alternating.
    for (i, p) in seen.iter_mut().enumerate() {
        p.y += if i % 2 == 0 { 5e-5 } else { -5e-5 };
    }
    let fit = fit_pivot_level(&believed, &seen).expect("fit");
    assert!((fit.rms_residual_m - 5e-5).abs() < 2e-5, "{fit:?}");
    let error = (fit.offset_m[1] - 0.005).abs();
    assert!(error < 4.0 * fit.standard_error_m[1] + 1e-6, "{fit:?}");
    assert!(
        fit.standard_error_m[1] > 1e-6 && fit.standard_error_m[1] < 1e-3,
        "{fit:?}"
    );
}

#[test]
fn touches_that_cannot_fix_the_pivot_are_refused() {
    let m = model(PivotGeometry::default());
    let line: Vec<_> = [-0.06, -0.03, 0.0, 0.03, 0.06]
        .iter()
        .map(|&x| {
            m.sensor_from_joints(&m.joints_for_sensor(&Point3::new(x, 0.0, 0.0)).unwrap())
                .unwrap()
        })
        .collect();
    assert!(matches!(
        fit_pivot_level(&m, &line),
        Err(LevelPivotError::Collinear { across_m }) if across_m < 1e-9
    ));
    assert!(matches!(
        fit_pivot_level(&m, &line[..4]),
        Err(LevelPivotError::TooFewTouches { touches: 4 })
    ));
    let mut bad = line.clone();
    bad[2].z = f64::NAN;
    assert!(matches!(
        fit_pivot_level(&m, &bad),
        Err(LevelPivotError::NonFinite { index: 2 })
    ));
    let mut far = line;
    far[1].x = 5.0;
    assert!(matches!(
        fit_pivot_level(&m, &far),
        Err(LevelPivotError::Kinematics { index: 1, .. })
    ));
}

#[test]
fn a_touch_layout_along_one_line_is_refused_before_anything_moves() {
    // The tissue procedure's patch: spread both ways.
    let patch = [
        [-0.08, 0.045],
        [0.08, 0.045],
        [-0.04, 0.01],
        [0.04, 0.01],
        [0.0, 0.04],
    ];
    assert_eq!(check_layout(&patch), Ok(()));
    // A diagonal strip 8 mm wide (RMS 4 mm across): along one line, whatever its direction.
    let strip: Vec<[f64; 2]> = (0..6)
        .map(|i| {
            let t = i as f64 * 0.02 - 0.05;
            let side = if i % 2 == 0 { 0.004 } else { -0.004 };
            [t + side * 0.6, t - side * 0.8]
        })
        .collect();
    match check_layout(&strip) {
        Err(e @ LevelPivotError::Collinear { across_m }) => {
            assert!((across_m - 0.004).abs() < 1e-3, "{across_m}");
            assert!(e.to_string().contains("along one line"), "{e}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        check_layout(&patch[..4]),
        Err(LevelPivotError::TooFewTouches { touches: 4 })
    );
    let mut bad = patch;
    bad[3][1] = f64::NAN;
    assert_eq!(
        check_layout(&bad),
        Err(LevelPivotError::NonFinite { index: 3 })
    );
}
