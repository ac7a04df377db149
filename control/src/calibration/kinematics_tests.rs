//! The calibration math fed by the project's kinematics, as the rig's procedures will feed it:
//! a pivot 5 mm from where the configuration says and a tissue frame yawed 5°, seen only
//! through the arm's (quantized) joint angles, are recovered.

use nalgebra::{Point3, Vector3};

use super::*;
use crate::calibration::tissue_frame::touched_point_in_base;
use crate::frames::{Gimbal, TissuePlacement};
use crate::kinematics::{
    ArmModel, DEFAULT_SENSOR_OFFSET_M, JointLimits, PhantomGeometry, PivotGeometry, phantom, pivot,
};

/// Motor encoder: 1024 counts per revolution through the capstans (docs/kinematics.md).
const CAPSTAN: [f64; 3] = [13.3, 11.2, 11.2];

fn quantized(q: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|j| {
        let step = std::f64::consts::TAU / (1024.0 * CAPSTAN[j]);
        (q[j] / step).round() * step
    })
}

#[test]
fn a_pivot_5_mm_off_the_configuration_is_found_from_the_arm_s_poses() {
    let configured = PivotGeometry::default();
    let [px, py, pz] = configured.pivot_in_base_m;
    let truth = PivotGeometry {
        pivot_in_base_m: [px + 0.003, py, pz - 0.004],
        ..configured
    };
    let p_true = Point3::from(truth.pivot_in_base_m);
    let arm = PhantomGeometry::default();
    let mut lines = Vec::new();
    // The rod through the true pivot, tip 0.28 m deep, in a cone of up to 0.3 rad.
    for (tilt, count) in [(0.0, 1), (0.15, 6), (0.3, 8)] {
        for k in 0..count {
            let azimuth = std::f64::consts::TAU * k as f64 / count as f64;
            let u = Vector3::new(tilt * azimuth.cos(), -1.0, tilt * azimuth.sin()).normalize();
            let tip = crate::frames::Tip(p_true + 0.28 * u);
            let gimbal = pivot::gimbal_from_tip(&truth, &tip).unwrap();
            // What the procedure sees: the encoders' counts, then forward kinematics, and the
            // rod's direction as a gimbal encoder would report it.
            let q = quantized(phantom::inverse(&arm, &gimbal).unwrap());
            let seen: Gimbal = phantom::forward(&arm, &q).unwrap();
            lines.push(RodLine::from_gimbal(&seen, u));
        }
    }
    let fit = fit_pivot(&lines).unwrap();
    let error = (fit.pivot.0 - p_true).norm();
    // Quantization moves the gimbal by up to ~0.1 mm; the pivot comes within that.
    assert!(error < 0.1e-3, "pivot off by {error} m: {fit:?}");
    assert!(error < 4.0 * fit.standard_error_m + 1e-6, "{fit:?}");
    assert!(
        fit.checks(&Tolerances::default()).iter().all(Check::passed),
        "{fit:?}"
    );
    // The configured pivot was 5 mm off; the calibrated one puts the tip where it is.
    let calibrated = fit.apply_to(&configured);
    let gimbal = phantom::forward(&arm, &[0.05, 0.5, 0.5]).unwrap();
    let true_tip = pivot::tip_from_gimbal(&truth, &gimbal).unwrap();
    let old_tip = pivot::tip_from_gimbal(&configured, &gimbal).unwrap();
    let new_tip = pivot::tip_from_gimbal(&calibrated, &gimbal).unwrap();
    assert!((old_tip.0 - true_tip.0).norm() > 5e-3);
    assert!((new_tip.0 - true_tip.0).norm() < 0.3e-3);
}

#[test]
fn a_tissue_frame_yawed_5_degrees_is_found_from_touches_at_the_arm_s_joints() {
    let configured = TissuePlacement {
        origin_in_base_m: [0.0, -0.3745, 0.055],
        yaw_rad: 0.0,
    };
    // The real tissue: yawed 5° about its configured origin and 2 mm lower.
    let truth = TissuePlacement {
        origin_in_base_m: [0.0, -0.3765, 0.055],
        yaw_rad: 5f64.to_radians(),
    };
    let model = |placement| {
        ArmModel::new(
            PhantomGeometry::default(),
            JointLimits::default(),
            PivotGeometry::default(),
            placement,
            DEFAULT_SENSOR_OFFSET_M,
        )
        .unwrap()
    };
    let (real, believed) = (model(truth), model(configured));
    // Touch at tissue (x, 0, z) of the real frame: the joints that put the sensor there,
    // read back (quantized) through the configured model.
    let touch = |x: f64, z: f64| {
        let q = quantized(real.joints_for_sensor(&Point3::new(x, 0.0, z)).unwrap());
        touched_point_in_base(&believed, &q).unwrap()
    };
    let surface: Vec<_> = [
        (-0.1, -0.05),
        (0.1, -0.05),
        (0.1, 0.05),
        (-0.1, 0.05),
        (0.0, 0.0),
    ]
    .iter()
    .map(|&(x, z)| touch(x, z))
    .collect();
    let artery = ArteryCourse {
        from: touch(-0.1, 0.0),
        to: touch(0.1, 0.0),
        lateral_m: 0.0,
    };
    let fit = fit_tissue_frame(&surface, Some(&artery), &configured).unwrap();
    let yaw_error = fit.placement.yaw_rad - truth.yaw_rad;
    assert!(
        yaw_error.abs() < 1e-3,
        "yaw off by {yaw_error} rad: {fit:?}"
    );
    let origin_error =
        Vector3::from(fit.placement.origin_in_base_m) - Vector3::from(truth.origin_in_base_m);
    assert!(
        origin_error.norm() < 0.2e-3,
        "origin off by {origin_error}: {fit:?}"
    );
    assert!(
        fit.checks(&Tolerances::default()).iter().all(Check::passed),
        "{fit:?}"
    );
    // The configured frame put a point 0.1 m along the artery 8.7 mm to the side.
    let p = truth.to_base(&Point3::new(0.1, 0.0, 0.0));
    assert!(configured.to_tissue(&p).z.abs() > 8e-3);
    assert!(fit.placement.to_tissue(&p).z.abs() < 0.2e-3);
}
