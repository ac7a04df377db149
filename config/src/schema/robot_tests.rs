use control::kinematics::phantom;
use control::motion::MotionParams;
use nalgebra::Vector3;

use super::*;
use crate::shipped::{LAB_CONFIG, SIM_CONFIG};
use crate::{Config, load_str};

/// The seed's workspace: a 28 x 14 cm tissue patch (26 cm paths plus room to either side).
const PATCH_HALF_X_M: f64 = 0.14;
const PATCH_HALF_Z_M: f64 = 0.07;

#[derive(Debug)]
struct Sweep {
    points: usize,
    worst_limit_margin_rad: f64,
    min_depth_m: f64,
    max_depth_m: f64,
    min_sensor_gain_m_per_rad: f64,
}

/// Every sensor position on a 5 mm grid over the patch (grown by `grow_m` on each side) at
/// each height must be reachable with joint rates available; returns the tightest numbers.
fn sweep(robot: &RobotSection, grow_m: f64, heights: &[f64]) -> Result<Sweep, String> {
    let arm = robot.arm_model().map_err(|e| e.to_string())?;
    let (hx, hz) = (PATCH_HALF_X_M + grow_m, PATCH_HALF_Z_M + grow_m);
    let n = |half: f64| (2.0 * half / 0.005).round() as i32;
    let mut s = Sweep {
        points: 0,
        worst_limit_margin_rad: f64::INFINITY,
        min_depth_m: f64::INFINITY,
        max_depth_m: 0.0,
        min_sensor_gain_m_per_rad: f64::INFINITY,
    };
    for &y in heights {
        for i in 0..=n(hx) {
            for k in 0..=n(hz) {
                let x = -hx + 2.0 * hx * f64::from(i) / f64::from(n(hx));
                let z = -hz + 2.0 * hz * f64::from(k) / f64::from(n(hz));
                let p = Point3::new(x, y, z);
                let sp = arm
                    .joint_setpoint(&p, &Vector3::new(0.03, 0.0, 0.0))
                    .map_err(|e| format!("({x:.3}, {y:.3}, {z:.3}): {e}"))?;
                let q = sp.position_rad;
                let back = arm.sensor_from_joints(&q).map_err(|e| e.to_string())?;
                if (back - p).norm() > 1e-9 {
                    return Err(format!(
                        "round trip missed at {p:?} by {}",
                        (back - p).norm()
                    ));
                }
                let depth = arm.depth_m(&q).map_err(|e| e.to_string())?;
                let gain = arm
                    .sensor_jacobian(&q)
                    .map_err(|e| e.to_string())?
                    .singular_values()
                    .min();
                s.points += 1;
                s.worst_limit_margin_rad = s
                    .worst_limit_margin_rad
                    .min(phantom::limit_margin_rad(arm.limits(), &q));
                s.min_depth_m = s.min_depth_m.min(depth);
                s.max_depth_m = s.max_depth_m.max(depth);
                s.min_sensor_gain_m_per_rad = s.min_sensor_gain_m_per_rad.min(gain);
            }
        }
    }
    Ok(s)
}

fn heights() -> [f64; 3] {
    // The default contact height, a deep press and the sensor lifted clear.
    [MotionParams::default().contact_height_m, -0.01, 0.005]
}

fn check_fits_with_margin(name: &str, robot: &RobotSection) {
    let s = sweep(robot, 0.0, &heights()).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(s.points, 3 * 57 * 29);
    // At least ~11 degrees from every joint and coupling limit anywhere on the patch.
    assert!(s.worst_limit_margin_rad > 0.2, "{name}: {s:?}");
    // Depth well inside its range, and joint rates well conditioned everywhere.
    assert!(
        s.min_depth_m > robot.pivot.min_depth_m + 0.05,
        "{name}: {s:?}"
    );
    assert!(
        s.max_depth_m < robot.pivot.max_depth_m - 0.02,
        "{name}: {s:?}"
    );
    assert!(s.min_sensor_gain_m_per_rad > 0.1, "{name}: {s:?}");
    // And 2 cm beyond the patch on every side is still reachable.
    sweep(robot, 0.02, &heights()).unwrap_or_else(|e| panic!("{name} grown: {e}"));
}

#[test]
fn the_default_placement_reaches_the_whole_seed_patch() {
    check_fits_with_margin("default", &RobotSection::default());
}

#[test]
fn the_shipped_configs_reach_the_whole_seed_patch() {
    for (name, text) in [SIM_CONFIG, LAB_CONFIG] {
        let c: Config = load_str(name, text).unwrap_or_else(|e| panic!("{e}"));
        check_fits_with_margin(name, &c.robot);
    }
}

#[test]
fn a_placement_too_far_away_fails_the_sweep() {
    // The sweep can fail: the tissue 20 cm farther from the arm is out of the depth range.
    let mut robot = RobotSection::default();
    robot.tissue.origin_in_base_m[1] -= 0.2;
    assert!(sweep(&robot, 0.0, &heights()).is_err());
}

#[test]
fn the_default_tissue_origin_is_under_the_pivot() {
    let r = RobotSection::default();
    let arm = r.arm_model().unwrap();
    let q = arm.joints_for_sensor(&Point3::origin()).unwrap();
    assert!((arm.depth_m(&q).unwrap() - DEFAULT_SURFACE_DEPTH_M).abs() < 1e-12);
    assert_eq!(r.tissue.yaw_rad, 0.0);
}

#[test]
fn validation_names_the_offending_fields() {
    let e = load_str::<RobotSection>(
        "robot.ron",
        "(\n  joint_limits: (coupling_max_rad: 1.7),\n)",
    )
    .unwrap_err();
    assert_eq!(e.problems.len(), 1, "{e}");
    assert_eq!(e.problems[0].field, "joint_limits.coupling_max_rad");
    assert_eq!(e.problems[0].line, Some(2));

    let e = load_str::<RobotSection>(
        "robot.ron",
        "(\n  tissue: (origin_in_base_m: (0.0, -1.5, 0.0), yaw_rad: 0.0),\n)",
    )
    .unwrap_err();
    assert_eq!(e.problems.len(), 1, "{e}");
    assert_eq!(e.problems[0].field, "tissue");
    assert!(e.problems[0].message.contains("insertion depth"), "{e}");

    let e = load_str::<RobotSection>(
        "robot.ron",
        "(\n  link_masses: (\n    gimbal: (mass_kg: -0.1),\n  ),\n)",
    )
    .unwrap_err();
    assert_eq!(e.problems[0].field, "link_masses.gimbal.mass_kg");
    assert_eq!(e.problems[0].line, Some(3));
}
