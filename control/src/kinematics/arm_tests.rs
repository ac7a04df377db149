use std::f64::consts::FRAC_PI_2;

use proptest::prelude::*;

use super::*;
use crate::kinematics::params::{
    DEFAULT_SENSOR_OFFSET_M, DEFAULT_SURFACE_DEPTH_M, tissue_under_pivot,
};

fn arm_with_yaw(yaw_rad: f64) -> ArmModel {
    let pivot = PivotGeometry::default();
    ArmModel::new(
        PhantomGeometry::default(),
        JointLimits::default(),
        pivot,
        tissue_under_pivot(
            &pivot,
            DEFAULT_SENSOR_OFFSET_M,
            DEFAULT_SURFACE_DEPTH_M,
            yaw_rad,
        ),
        DEFAULT_SENSOR_OFFSET_M,
    )
    .unwrap()
}

/// The default arm over the default tissue placement (shared with other kinematics tests).
pub(crate) fn arm() -> ArmModel {
    arm_with_yaw(0.0)
}

#[test]
fn the_default_centre_pose_is_the_designed_one() {
    // Sensor centre on the surface at the tissue origin: rod vertical, tip 0.28 m deep, arm
    // near θ = (0, 0.5, 0.5) (the pivot is rounded to the millimetre).
    let q = arm().joints_for_sensor(&Point3::origin()).unwrap();
    assert!(q[0].abs() < 1e-12);
    assert!(
        (q[1] - 0.5).abs() < 0.01 && (q[2] - 0.5).abs() < 0.01,
        "{q:?}"
    );
    assert!((arm().depth_m(&q).unwrap() - DEFAULT_SURFACE_DEPTH_M).abs() < 1e-12);
    let lever = arm().lever_ratio(&q).unwrap();
    assert!((lever - (0.495 - 0.28) / 0.28).abs() < 1e-12);
}

#[test]
fn moving_the_sensor_moves_the_gimbal_the_other_way_by_the_lever() {
    let arm = arm();
    let q0 = arm.joints_for_sensor(&Point3::origin()).unwrap();
    let q1 = arm.joints_for_sensor(&Point3::new(1e-6, 0.0, 0.0)).unwrap();
    let g0 = phantom::forward(arm.phantom(), &q0).unwrap();
    let g1 = phantom::forward(arm.phantom(), &q1).unwrap();
    let moved = (g1.0.x - g0.0.x) / 1e-6;
    assert!(
        (moved + arm.lever_ratio(&q0).unwrap()).abs() < 1e-5,
        "{moved}"
    );
}

#[test]
fn bad_targets_are_refused_never_nan() {
    let arm = arm();
    let pivot_in_tissue = arm
        .placement()
        .to_tissue(&Point3::from(arm.pivot().pivot_in_base_m));
    let targets = [
        Point3::new(f64::NAN, 0.0, 0.0),
        Point3::new(0.0, f64::INFINITY, 0.0),
        Point3::new(1e300, 0.0, -1e300),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, -0.5, 0.0),
        // At the pivot and just below it.
        pivot_in_tissue + arm.sensor_offset_m(),
        pivot_in_tissue + arm.sensor_offset_m() + Vector3::new(0.0, -0.01, 0.0),
    ];
    for t in targets {
        let err = arm.joints_for_sensor(&t);
        assert!(err.is_err(), "{t:?} -> {err:?}");
        assert!(arm.joint_setpoint(&t, &Vector3::zeros()).is_err());
    }
    let ok = Point3::new(0.01, 0.0, 0.01);
    assert!(matches!(
        arm.joint_setpoint(&ok, &Vector3::new(f64::NAN, 0.0, 0.0)),
        Err(KinematicsError::NonFinite { .. })
    ));
    // A reachable point whose base angle is beyond the θ1 limit: the limit says so.
    let wide = Point3::new(0.0, 0.0, 0.0);
    let q = arm.joints_for_sensor(&wide).unwrap();
    let narrow = ArmModel::new(
        *arm.phantom(),
        JointLimits {
            min_rad: [q[0] + 0.01, -0.35, -0.45],
            ..*arm.limits()
        },
        *arm.pivot(),
        *arm.placement(),
        arm.sensor_offset_m().into(),
    )
    .unwrap();
    assert!(matches!(
        narrow.joints_for_sensor(&wide),
        Err(KinematicsError::JointLimit { joint: 0, .. })
    ));
}

#[test]
fn near_full_stretch_joint_rates_are_refused() {
    // Open the coupling range to the whole branch and ask for a pose a hair from stretch.
    let base = arm();
    let limits = JointLimits {
        min_rad: [-1.5, -1.5, -1.5],
        max_rad: [1.5, 1.5, 2.5],
        coupling_min_rad: -FRAC_PI_2,
        coupling_max_rad: FRAC_PI_2,
    };
    let stretched = ArmModel::new(
        *base.phantom(),
        limits,
        *base.pivot(),
        *base.placement(),
        base.sensor_offset_m().into(),
    )
    .unwrap();
    // Find a stretched pose whose tip depth lies in range: vary θ2 with θ3 = θ2 + π/2 − ε.
    let eps = 1e-7;
    let q = (0..200)
        .map(|i| -0.5 + 0.01 * f64::from(i))
        .map(|t2| [0.0, t2, t2 + FRAC_PI_2 - eps])
        .find(|q| stretched.sensor_from_joints(q).is_ok())
        .expect("a stretched pose with the tip in the depth range");
    let s = stretched.sensor_from_joints(&q).unwrap();
    match stretched.joint_setpoint(&s, &Vector3::new(0.01, 0.0, 0.0)) {
        Err(KinematicsError::NearSingular {
            sigma_min_m_per_rad,
            ..
        }) => assert!(sigma_min_m_per_rad < 1e-3),
        other => panic!("{other:?}"),
    }
}

#[test]
fn invalid_geometry_is_refused() {
    let a = arm();
    let build = |phantom, limits, pivot, offset: [f64; 3]| {
        ArmModel::new(phantom, limits, pivot, *a.placement(), offset)
    };
    let (p, l, v) = (*a.phantom(), *a.limits(), *a.pivot());
    let o: [f64; 3] = a.sensor_offset_m().into();
    let cases = [
        build(PhantomGeometry { l1_m: 0.0, ..p }, l, v, o),
        build(
            PhantomGeometry {
                l2_m: f64::NAN,
                ..p
            },
            l,
            v,
            o,
        ),
        build(
            p,
            JointLimits {
                coupling_max_rad: 2.0,
                ..l
            },
            v,
            o,
        ),
        build(
            p,
            JointLimits {
                min_rad: [0.0, 2.0, 0.0],
                ..l
            },
            v,
            o,
        ),
        build(
            p,
            l,
            PivotGeometry {
                min_depth_m: 0.0,
                ..v
            },
            o,
        ),
        build(
            p,
            l,
            PivotGeometry {
                max_depth_m: 0.6,
                ..v
            },
            o,
        ),
        build(
            p,
            l,
            PivotGeometry {
                rod_length_m: -1.0,
                ..v
            },
            o,
        ),
        build(p, l, v, [0.0, f64::NAN, 0.0]),
    ];
    for (i, c) in cases.iter().enumerate() {
        assert!(
            matches!(c, Err(KinematicsError::InvalidGeometry { .. })),
            "case {i}: {c:?}"
        );
    }
}

/// Sensor positions over (and a little beyond) the seed's tissue patch.
fn sensor_points() -> impl Strategy<Value = Point3<f64>> {
    (-0.16f64..0.16, -0.01f64..0.01, -0.09f64..0.09).prop_map(|(x, y, z)| Point3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn sensor_round_trips(s in sensor_points(), yaw in prop_oneof![Just(0.0), -0.3f64..0.3]) {
        let arm = arm_with_yaw(yaw);
        let q = arm.joints_for_sensor(&s).unwrap();
        let back = arm.sensor_from_joints(&q).unwrap();
        prop_assert!((back - s).norm() < 1e-9, "{:?} -> {:?}", s, back);
        let sp = arm.surface_point(&q).unwrap();
        prop_assert!((sp.x_m - s.x).abs() < 1e-9 && (sp.z_m - s.z).abs() < 1e-9);
    }

    #[test]
    fn sensor_jacobian_matches_finite_differences(s in sensor_points(), yaw in -0.3f64..0.3) {
        let arm = arm_with_yaw(yaw);
        let q = arm.joints_for_sensor(&s).unwrap();
        let j = arm.sensor_jacobian(&q).unwrap();
        let h = 1e-6;
        for col in 0..3 {
            let (mut qp, mut qm) = (q, q);
            qp[col] += h;
            qm[col] -= h;
            let fd = (arm.sensor_from_joints(&qp).unwrap() - arm.sensor_from_joints(&qm).unwrap())
                / (2.0 * h);
            prop_assert!((fd - j.column(col)).norm() < 1e-7, "column {}", col);
        }
    }

    #[test]
    fn joint_rates_reproduce_the_sensor_velocity(
        s in sensor_points(),
        vx in -0.03f64..0.03,
        vz in -0.03f64..0.03,
    ) {
        let arm = arm();
        let v = Vector3::new(vx, 0.0, vz);
        let sp = arm.joint_setpoint(&s, &v).unwrap();
        let j = arm.sensor_jacobian(&sp.position_rad).unwrap();
        let back = j * Vector3::from(sp.velocity_rad_s);
        prop_assert!((back - v).norm() < 1e-12);
        // And a short step along the rates lands where the velocity points.
        let dt = 1e-6;
        let q1: Joints = std::array::from_fn(|i| sp.position_rad[i] + dt * sp.velocity_rad_s[i]);
        let moved = (arm.sensor_from_joints(&q1).unwrap() - s) / dt;
        prop_assert!((moved - v).norm() < 1e-6);
    }
}
