//! Prints the numbers behind docs/kinematics.md for the default robot and control settings:
//! the sweep of the seed's tissue patch, the stiffness and force the PD gives at the sensor,
//! and the closed-loop poles of each joint.
//!
//! cargo run -p pulsetrack-config --example kinematics_report

use control::kinematics::phantom;
use control::pd::stability::{
    JOINT_INERTIA_MAX_KG_M2, JOINT_INERTIA_MIN_KG_M2, JointLoop, RateSource,
};
use nalgebra::{Matrix3, Point3};
use pulsetrack_config::schema::{ControlSection, RobotSection};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let robot = RobotSection::default();
    let control = ControlSection::default();
    let arm = robot.arm_model()?;
    let h = control.motion.contact_height_m;
    println!("pivot {:?}, tissue {:?}", robot.pivot, robot.tissue);

    // Sweep of the patch at the contact height.
    let (mut margin, mut dmin, mut dmax) = (f64::INFINITY, f64::INFINITY, 0.0f64);
    let (mut smin, mut smax, mut lmin, mut lmax) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    let mut qmin = [f64::INFINITY; 3];
    let mut qmax = [f64::NEG_INFINITY; 3];
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..=56 {
        for k in 0..=28 {
            let p = Point3::new(
                -0.14 + 0.005 * f64::from(i),
                h,
                -0.07 + 0.005 * f64::from(k),
            );
            let q = arm.joints_for_sensor(&p)?;
            margin = margin.min(phantom::limit_margin_rad(arm.limits(), &q));
            let d = arm.depth_m(&q)?;
            dmin = dmin.min(d);
            dmax = dmax.max(d);
            let sv = arm.sensor_jacobian(&q)?.singular_values();
            smin = smin.min(sv.min());
            smax = smax.max(sv.max());
            let l = arm.lever_ratio(&q)?;
            lmin = lmin.min(l);
            lmax = lmax.max(l);
            for j in 0..3 {
                qmin[j] = qmin[j].min(q[j]);
                qmax[j] = qmax[j].max(q[j]);
            }
            cmin = cmin.min(q[2] - q[1]);
            cmax = cmax.max(q[2] - q[1]);
        }
    }
    println!("patch x ±0.14 z ±0.07 at y = {h} m, 5 mm grid:");
    println!(
        "  joints used: θ1 {:.3}..{:.3}, θ2 {:.3}..{:.3}, θ3 {:.3}..{:.3}, θ3−θ2 {:.3}..{:.3} rad",
        qmin[0], qmax[0], qmin[1], qmax[1], qmin[2], qmax[2], cmin, cmax
    );
    println!(
        "  nearest limit {margin:.3} rad; depth {dmin:.4}..{dmax:.4} m; lever {lmin:.3}..{lmax:.3}"
    );
    println!("  singular values of d sensor/d q: {smin:.3}..{smax:.3} m/rad");

    // Stiffness and force at the sensor from the PD at three points.
    let kp = Matrix3::from_diagonal(&control.pd.kp_nm_per_rad.into());
    for (x, z) in [(0.0, 0.0), (0.14, 0.07), (-0.14, -0.07)] {
        let q = arm.joints_for_sensor(&Point3::new(x, h, z))?;
        let j = arm.sensor_jacobian(&q)?;
        let ji = j.try_inverse().ok_or("singular")?;
        let k = ji.transpose() * kp * ji;
        // Largest force along each tissue axis within the torque limits: τ = Jᵀ f.
        let fmax: Vec<f64> = (0..3)
            .map(|axis| {
                (0..3)
                    .map(|jt| control.pd.torque_limit_nm[jt] / j[(axis, jt)].abs())
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        println!(
            "  at ({x:+.2}, {z:+.2}): stiffness x {:.0} y {:.0} z {:.0} N/m; force at the torque limits x {:.2} y {:.2} z {:.2} N",
            k[(0, 0)],
            k[(1, 1)],
            k[(2, 2)],
            fmax[0],
            fmax[1],
            fmax[2]
        );
    }

    // Closed-loop poles per joint.
    for j in 0..3 {
        let (kp, kd) = (control.pd.kp_nm_per_rad[j], control.pd.kd_nm_s_per_rad[j]);
        for inertia in [JOINT_INERTIA_MIN_KG_M2[j], JOINT_INERTIA_MAX_KG_M2[j]] {
            let mut line = format!("joint {j} kp {kp} kd {kd} J {inertia:.1e}:");
            for (rate, delay) in [
                (RateSource::Measured, false),
                (RateSource::BackwardDifference, true),
            ] {
                let m = JointLoop {
                    inertia_kg_m2: inertia,
                    kp_nm_per_rad: kp,
                    kd_nm_s_per_rad: kd,
                    period_s: 1.0 / control.rate_hz,
                    rate,
                    one_cycle_delay: delay,
                };
                let doubled = JointLoop {
                    kp_nm_per_rad: 2.0 * kp,
                    kd_nm_s_per_rad: 2.0 * kd,
                    ..m
                };
                line += &format!(
                    "  [{rate:?}{}] ρ {:.4} ζ {:.3} (2x gains ρ {:.4})",
                    if delay { "+delay" } else { "" },
                    m.spectral_radius(),
                    m.min_damping_ratio(),
                    doubled.spectral_radius()
                );
            }
            println!("{line}");
        }
    }
    Ok(())
}
