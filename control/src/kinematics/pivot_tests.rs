use proptest::prelude::*;

use super::*;

fn pivot() -> PivotGeometry {
    PivotGeometry::default()
}

/// A tip at `depth` below the pivot, tilted `tilt` from vertical toward azimuth `azimuth`.
fn tip_at(depth: f64, tilt: f64, azimuth: f64) -> Tip {
    let dir = Vector3::new(
        tilt.sin() * azimuth.cos(),
        -tilt.cos(),
        tilt.sin() * azimuth.sin(),
    );
    Tip(pivot_point(&pivot()).0 + depth * dir)
}

#[test]
fn rod_passes_through_the_pivot_with_its_length() {
    let p = pivot();
    let tip = tip_at(0.5 * (p.min_depth_m + p.max_depth_m), 0.4, 1.0);
    let g = gimbal_from_tip(&p, &tip).unwrap();
    let pp = pivot_point(&p).0;
    assert!(((tip.0 - g.0).norm() - p.rod_length_m).abs() < 1e-15);
    // P lies on the segment G..T, at distance L − d from G.
    let u = (tip.0 - g.0) / p.rod_length_m;
    let along = (pp - g.0).dot(&u);
    assert!(((pp - g.0) - along * u).norm() < 1e-15);
    let depth = (tip.0 - pp).norm();
    assert!((along - (p.rod_length_m - depth)).abs() < 1e-15);
    assert!((depth_m(&p, &g).unwrap() - depth).abs() < 1e-15);
}

#[test]
fn a_vertical_rod_by_hand() {
    let p = PivotGeometry {
        rod_length_m: 0.5,
        pivot_in_base_m: [0.1, -0.2, 0.3],
        min_depth_m: 0.05,
        max_depth_m: 0.4,
    };
    let g = Gimbal(Point3::new(0.1, 0.0, 0.3));
    let t = tip_from_gimbal(&p, &g).unwrap();
    assert!((t.0 - Point3::new(0.1, -0.5, 0.3)).norm() < 1e-15);
    // Across the rod the tip moves d/(L − d) = 0.3/0.2 as far, the other way.
    let j = tip_jacobian(&p, &g).unwrap();
    assert!((j[(0, 0)] + 1.5).abs() < 1e-12 && (j[(2, 2)] + 1.5).abs() < 1e-12);
    assert!((j[(1, 1)] - 1.0).abs() < 1e-12);
    assert!((lever_ratio(&p, 0.3).unwrap() - 0.2 / 0.3).abs() < 1e-15);
}

#[test]
fn tips_near_the_pivot_or_outside_the_depth_range_are_refused() {
    let p = pivot();
    for depth in [0.0, 1e-12, 1e-6, 0.5 * p.min_depth_m, p.min_depth_m - 1e-9] {
        let err = gimbal_from_tip(&p, &tip_at(depth, 0.3, 0.0)).unwrap_err();
        match err {
            KinematicsError::AtPivot { distance_m, .. } => assert!(distance_m < 1e-9),
            KinematicsError::DepthOutOfRange { depth_m, min_m, .. } => {
                assert!((depth_m - depth).abs() < 1e-12 && min_m == p.min_depth_m)
            }
            other => panic!("depth {depth}: {other}"),
        }
    }
    assert!(gimbal_from_tip(&p, &tip_at(p.min_depth_m, 0.3, 0.0)).is_ok());
    assert!(gimbal_from_tip(&p, &tip_at(p.max_depth_m, 0.3, 0.0)).is_ok());
    for depth in [p.max_depth_m + 1e-9, p.rod_length_m, 10.0] {
        assert!(matches!(
            gimbal_from_tip(&p, &tip_at(depth, -0.2, 2.0)),
            Err(KinematicsError::DepthOutOfRange { .. })
        ));
        assert!(gimbal_jacobian(&p, &tip_at(depth, -0.2, 2.0)).is_err());
    }
    let nan = Tip(Point3::new(f64::NAN, 0.0, 0.0));
    assert!(matches!(
        gimbal_from_tip(&p, &nan),
        Err(KinematicsError::NonFinite { .. })
    ));
}

#[test]
fn gimbal_on_the_pivot_or_out_of_range_is_refused() {
    let p = pivot();
    let pp = pivot_point(&p).0;
    assert!(matches!(
        tip_from_gimbal(&p, &Gimbal(pp)),
        Err(KinematicsError::AtPivot { .. })
    ));
    assert!(matches!(
        rod_pose(&p, &Gimbal(pp + Vector3::new(0.0, 1e-10, 0.0))),
        Err(KinematicsError::AtPivot { .. })
    ));
    // Gimbal so close to the pivot that the tip is too deep, and so far that the rod is
    // withdrawn above the pivot (negative depth).
    for (above, expect_depth) in [(0.01, p.rod_length_m - 0.01), (0.6, p.rod_length_m - 0.6)] {
        let g = Gimbal(pp + Vector3::new(0.0, above, 0.0));
        match tip_from_gimbal(&p, &g) {
            Err(KinematicsError::DepthOutOfRange { depth_m, .. }) => {
                assert!((depth_m - expect_depth).abs() < 1e-12)
            }
            other => panic!("{other:?}"),
        }
        assert!(tip_jacobian(&p, &g).is_err());
        // The unguarded pose still answers, for diagnostics.
        assert!((rod_pose(&p, &g).unwrap().depth_m - expect_depth).abs() < 1e-12);
    }
}

#[test]
fn lever_refuses_depths_outside_the_rod() {
    let p = pivot();
    for d in [0.0, -0.1, p.rod_length_m, 1.0] {
        assert!(matches!(
            lever_ratio(&p, d),
            Err(KinematicsError::DepthOutOfRange { .. })
        ));
    }
    assert!(matches!(
        lever_ratio(&p, f64::NAN),
        Err(KinematicsError::NonFinite { .. })
    ));
}

fn tips_in_range() -> impl Strategy<Value = Tip> {
    let p = PivotGeometry::default();
    (p.min_depth_m..=p.max_depth_m, 0.0f64..1.2, -3.2f64..3.2)
        .prop_map(|(d, tilt, az)| tip_at(d, tilt, az))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn tip_gimbal_round_trip(tip in tips_in_range()) {
        let p = pivot();
        let g = gimbal_from_tip(&p, &tip).unwrap();
        let back = tip_from_gimbal(&p, &g).unwrap();
        prop_assert!((back.0 - tip.0).norm() < 1e-12);
    }

    #[test]
    fn jacobians_match_finite_differences(tip in tips_in_range()) {
        let p = pivot();
        // Stay clear of the range ends so that the ±h probes stay inside.
        let d = (tip.0 - pivot_point(&p).0).norm();
        prop_assume!(d > p.min_depth_m + 1e-4 && d < p.max_depth_m - 1e-4);
        let g = gimbal_from_tip(&p, &tip).unwrap();
        let jg = gimbal_jacobian(&p, &tip).unwrap();
        let jt = tip_jacobian(&p, &g).unwrap();
        let h = 1e-6;
        for col in 0..3 {
            let e = Vector3::ith(col, h);
            let fd_g = (gimbal_from_tip(&p, &Tip(tip.0 + e)).unwrap().0
                - gimbal_from_tip(&p, &Tip(tip.0 - e)).unwrap().0) / (2.0 * h);
            prop_assert!((fd_g - jg.column(col)).norm() < 1e-7, "dG/dT col {}", col);
            let fd_t = (tip_from_gimbal(&p, &Gimbal(g.0 + e)).unwrap().0
                - tip_from_gimbal(&p, &Gimbal(g.0 - e)).unwrap().0) / (2.0 * h);
            prop_assert!((fd_t - jt.column(col)).norm() < 1e-7, "dT/dG col {}", col);
        }
        // The two maps are inverse, so are their Jacobians.
        prop_assert!((jg * jt - Matrix3::identity()).norm() < 1e-9);
    }

    #[test]
    fn lateral_tip_motion_needs_the_lever_times_as_much_gimbal_motion(
        tip in tips_in_range(),
        az in -3.2f64..3.2,
    ) {
        let p = pivot();
        let d = (tip.0 - pivot_point(&p).0).norm();
        prop_assume!(d > p.min_depth_m + 1e-4 && d < p.max_depth_m - 1e-4);
        let u = (tip.0 - pivot_point(&p).0) / d;
        // A unit direction across the rod.
        let seed = Vector3::new(az.cos(), 0.3, az.sin());
        let across = (seed - u * seed.dot(&u)).normalize();
        let delta = 1e-7;
        let g0 = gimbal_from_tip(&p, &tip).unwrap();
        let g1 = gimbal_from_tip(&p, &Tip(tip.0 + delta * across)).unwrap();
        let moved = (g1.0 - g0.0).dot(&across) / delta;
        prop_assert!((moved + lever_ratio(&p, d).unwrap()).abs() < 1e-6);
    }
}
