use std::f64::consts::FRAC_PI_2;

use nalgebra::{Point3, Vector3};
use proptest::prelude::*;

use super::*;

fn geom() -> PhantomGeometry {
    PhantomGeometry::default()
}

/// The gimbal point built link by link from the shoulder, independently of `forward`.
fn chain(geom: &PhantomGeometry, q: &Joints) -> (Point3<f64>, Point3<f64>, Point3<f64>) {
    let shoulder = Point3::new(0.0, geom.l2_m, -geom.l1_m);
    let (s1, c1) = q[0].sin_cos();
    let upper = Vector3::new(s1 * q[1].cos(), q[1].sin(), c1 * q[1].cos());
    let fore = Vector3::new(s1 * q[2].sin(), -q[2].cos(), c1 * q[2].sin());
    let elbow = shoulder + geom.l1_m * upper;
    (shoulder, elbow, elbow + geom.l2_m * fore)
}

fn gimbal_at(distance_m: f64, elevation_rad: f64, yaw_rad: f64) -> Gimbal {
    let g = geom();
    let r = distance_m * elevation_rad.cos();
    Gimbal(Point3::new(
        yaw_rad.sin() * r,
        g.l2_m + distance_m * elevation_rad.sin(),
        -g.l1_m + yaw_rad.cos() * r,
    ))
}

fn shoulder_distance(g: &Gimbal) -> f64 {
    let geom = geom();
    (g.0 - Point3::new(0.0, geom.l2_m, -geom.l1_m)).norm()
}

#[test]
fn home_pose_is_the_origin_and_back() {
    let g = forward(&geom(), &[0.0; 3]).unwrap();
    assert!(g.0.coords.norm() < 1e-15);
    let q = inverse(&geom(), &g).unwrap();
    assert!(q.iter().all(|v| v.abs() < 1e-12), "{q:?}");
}

#[test]
fn forward_matches_the_link_chain() {
    let geom = geom();
    for q in [[0.3, 0.5, 0.2], [-0.8, -0.2, 1.1], [0.0, 1.0, -0.4]] {
        let (shoulder, elbow, tip) = chain(&geom, &q);
        assert!(((elbow - shoulder).norm() - geom.l1_m).abs() < 1e-15);
        assert!(((tip - elbow).norm() - geom.l2_m).abs() < 1e-15);
        let g = forward(&geom, &q).unwrap();
        assert!((g.0 - tip).norm() < 1e-15, "{q:?}");
    }
}

#[test]
fn a_known_pose_by_hand() {
    // θ = (0, 0, π/2): upper arm horizontal, forearm pointing straight at the operator.
    let g = forward(&geom(), &[0.0, 0.0, FRAC_PI_2]).unwrap();
    assert!((g.0 - Point3::new(0.0, 0.170, 0.170)).norm() < 1e-15);
    // Base turned a quarter: the same reach now lies along +x.
    let g = forward(&geom(), &[FRAC_PI_2, 0.0, 0.0]).unwrap();
    assert!((g.0 - Point3::new(0.215, 0.0, -0.215)).norm() < 1e-15);
}

#[test]
fn inverse_takes_the_elbow_up_branch() {
    // Both branches reach this point; the Phantom's is the one with θ3 − θ2 < π/2 and the
    // elbow above the shoulder–gimbal line.
    let q = [0.1, 0.4, 0.3];
    let g = forward(&geom(), &q).unwrap();
    let back = inverse(&geom(), &g).unwrap();
    let (shoulder, elbow, tip) = chain(&geom(), &back);
    let line = (tip - shoulder).normalize();
    let to_elbow = elbow - shoulder;
    let height_above_line = (to_elbow - line * to_elbow.dot(&line)).y;
    assert!(height_above_line > 0.0);
    assert!((back[2] - back[1] - (q[2] - q[1])).abs() < 1e-12);
}

#[test]
fn full_stretch_is_handled_without_nan() {
    let geom = geom();
    let (_, max) = reach_m(&geom);
    let (l1, l2) = (geom.l1_m, geom.l2_m);
    for delta in [1e-3, 1e-6, 1e-9, 1e-12, 0.0, -5e-10] {
        let target = gimbal_at(max - delta, 0.3, 0.2);
        let q = inverse(&geom, &target).unwrap_or_else(|e| panic!("delta {delta}: {e}"));
        assert!(q.iter().all(|v| v.is_finite()));
        let back = forward(&geom, &q).unwrap();
        // Past the boundary (inside the tolerance) the answer is the boundary point.
        let expected_err = (-delta).max(0.0);
        assert!(
            ((back.0 - target.0).norm() - expected_err).abs() < 1e-12,
            "delta {delta}: {}",
            (back.0 - target.0).norm()
        );
        // The elbow angle against the law of cosines where acos is still well conditioned.
        let d = max - delta.max(0.0);
        let gamma = q[1] - q[2] + FRAC_PI_2;
        if delta >= 1e-9 {
            let cos_gamma = (d * d - l1 * l1 - l2 * l2) / (2.0 * l1 * l2);
            assert!((gamma - cos_gamma.acos()).abs() < 1e-7, "delta {delta}");
        }
        // Very near stretch γ ≈ √(2 (l1 + l2) δ / (l1 l2)), which acos cannot resolve. The
        // position fixes γ only to the square root of its rounding: one ulp of the distance
        // (5.6e-17 m) is 3.4e-8 rad of elbow angle here.
        if delta <= 1e-6 {
            let approx = (2.0 * (l1 + l2) * delta.max(0.0) / (l1 * l2)).sqrt();
            assert!(
                (gamma - approx).abs() <= 1e-3 * approx + 1e-7,
                "delta {delta}: {gamma} vs {approx}"
            );
        }
    }
}

#[test]
fn out_of_reach_is_an_error_never_nan() {
    let geom = geom();
    let (min, max) = reach_m(&geom);
    for d in [
        max + 2e-9,
        max + 1e-6,
        max + 1.0,
        1e300,
        min - 1e-6,
        min * 0.5,
    ] {
        let err = inverse(&geom, &gimbal_at(d, -0.4, 0.5)).unwrap_err();
        match err {
            KinematicsError::OutOfReach {
                distance_m,
                min_m,
                max_m,
            } => {
                assert!((distance_m - d).abs() <= 1e-9 * d.max(1.0));
                assert_eq!((min_m, max_m), (min, max));
            }
            other => panic!("{d}: {other}"),
        }
    }
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let err = inverse(&geom, &Gimbal(Point3::new(0.1, bad, 0.0))).unwrap_err();
        assert!(matches!(err, KinematicsError::NonFinite { .. }));
        let err = forward(&geom, &[0.0, bad, 0.0]).unwrap_err();
        assert!(matches!(err, KinematicsError::NonFinite { .. }));
        let err = jacobian(&geom, &[bad, 0.0, 0.0]).unwrap_err();
        assert!(matches!(err, KinematicsError::NonFinite { .. }));
    }
}

#[test]
fn base_axis_is_singular() {
    let geom = geom();
    let on_axis = Gimbal(Point3::new(0.0, 0.1, -geom.l1_m));
    assert!(matches!(
        inverse(&geom, &on_axis),
        Err(KinematicsError::Singular { .. })
    ));
    // Equal links fold onto the shoulder itself: singular, not out of reach.
    let equal = PhantomGeometry {
        l1_m: 0.2,
        l2_m: 0.2,
    };
    let shoulder = Gimbal(Point3::new(0.0, 0.2, -0.2 + 1e-12));
    assert!(matches!(
        inverse(&equal, &shoulder),
        Err(KinematicsError::Singular { .. })
    ));
}

#[test]
fn limits_are_checked_per_joint_and_on_the_coupling() {
    let limits = JointLimits::default();
    assert!(check_limits(&limits, &[0.0, 0.3, 0.4]).is_ok());
    // Each limit is inclusive.
    let edge = [limits.max_rad[0], 0.3, 0.4];
    assert!(check_limits(&limits, &edge).is_ok());
    for joint in 0..3 {
        let mut q = [0.0, 0.3, 0.4];
        q[joint] = limits.max_rad[joint] + 1e-9;
        match check_limits(&limits, &q) {
            Err(KinematicsError::JointLimit { joint: j, .. }) if j == joint => {}
            other => panic!("joint {joint}: {other:?}"),
        }
        q[joint] = limits.min_rad[joint] - 1e-9;
        assert!(matches!(
            check_limits(&limits, &q),
            Err(KinematicsError::JointLimit { .. })
        ));
    }
    // Each joint in range, the pair not: θ3 − θ2 just past either coupling limit.
    for (theta2, coupling) in [
        (0.0, limits.coupling_max_rad + 1e-6),
        (1.0, limits.coupling_min_rad - 1e-6),
    ] {
        let q = [0.0, theta2, theta2 + coupling];
        assert!(
            q[2] > limits.min_rad[2] && q[2] < limits.max_rad[2],
            "{q:?}"
        );
        match check_limits(&limits, &q) {
            Err(KinematicsError::CouplingLimit { value_rad, .. }) => {
                assert!((value_rad - coupling).abs() < 1e-12)
            }
            other => panic!("{other:?}"),
        }
        let inside = [0.0, theta2, theta2 + coupling.clamp(-0.9, 0.8)];
        assert!(check_limits(&limits, &inside).is_ok());
    }
    assert!(matches!(
        check_limits(&limits, &[0.0, f64::NAN, 0.0]),
        Err(KinematicsError::NonFinite { .. })
    ));
}

#[test]
fn limit_margin_is_the_nearest_limit() {
    let limits = JointLimits::default();
    let q = [0.0, 0.3, 0.4];
    let m = limit_margin_rad(&limits, &q);
    let expected = [
        q[0] - limits.min_rad[0],
        limits.max_rad[0] - q[0],
        q[1] - limits.min_rad[1],
        limits.max_rad[1] - q[1],
        q[2] - limits.min_rad[2],
        limits.max_rad[2] - q[2],
        (q[2] - q[1]) - limits.coupling_min_rad,
        limits.coupling_max_rad - (q[2] - q[1]),
    ]
    .into_iter()
    .fold(f64::INFINITY, f64::min);
    assert_eq!(m, expected);
}

/// Joint angles anywhere on the elbow-up branch with the gimbal in front of the base axis.
fn branch_joints() -> impl Strategy<Value = Joints> {
    (
        -1.5f64..1.5,
        -1.3f64..1.5,
        (-FRAC_PI_2 + 1e-3)..(FRAC_PI_2 - 1e-3),
    )
        .prop_map(|(t1, t2, c)| [t1, t2, t2 + c])
        .prop_filter("gimbal in front of the base axis", |q| {
            let g = PhantomGeometry::default();
            g.l1_m * q[1].cos() + g.l2_m * q[2].sin() > 1e-3
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn joints_round_trip_over_the_branch(q in branch_joints()) {
        let g = forward(&geom(), &q).unwrap();
        let back = inverse(&geom(), &g).unwrap();
        for i in 0..3 {
            prop_assert!((back[i] - q[i]).abs() < 1e-9, "{:?} -> {:?}", q, back);
        }
    }

    #[test]
    fn points_round_trip_over_the_reach(
        frac in 0.0f64..=1.0,
        elevation in -1.5f64..1.5,
        yaw in -3.0f64..3.0,
    ) {
        let (min, max) = reach_m(&geom());
        let target = gimbal_at(min + frac * (max - min), elevation, yaw);
        let q = inverse(&geom(), &target).unwrap();
        let back = forward(&geom(), &q).unwrap();
        prop_assert!((back.0 - target.0).norm() < 1e-9);
        prop_assert!((shoulder_distance(&back) - shoulder_distance(&target)).abs() < 1e-9);
    }

    #[test]
    fn jacobian_matches_finite_differences(q in branch_joints()) {
        let geom = geom();
        let j = jacobian(&geom, &q).unwrap();
        let h = 1e-6;
        for col in 0..3 {
            let (mut qp, mut qm) = (q, q);
            qp[col] += h;
            qm[col] -= h;
            let fd = (forward(&geom, &qp).unwrap().0 - forward(&geom, &qm).unwrap().0) / (2.0 * h);
            let err = (fd - j.column(col)).norm();
            prop_assert!(err < 1e-8, "column {} error {}", col, err);
        }
    }
}
