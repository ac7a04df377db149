//! Cost of the per-cycle control path at 1 kHz: kinematics, joint setpoint, PD step.
//!
//! cargo bench -p pulsetrack-control --bench cycle
//!
//! Each line is the median over 31 batches of the time per call, ns; the ratio column is
//! each line against the PD step measured in the same run.

use std::hint::black_box;
use std::time::Instant;

use nalgebra::{Point3, Vector3};
use pulsetrack_control::calibration::{
    JointSettings, JointSweep, StopTargets, SweepPlan, through_zero,
};
use pulsetrack_control::frames::SurfacePoint;
use pulsetrack_control::kinematics::{
    ArmModel, DEFAULT_SENSOR_OFFSET_M, DEFAULT_SURFACE_DEPTH_M, JointLimits, PhantomGeometry,
    PivotGeometry, RodMechanics, phantom, tissue_under_pivot,
};
use pulsetrack_control::motion::{MotionParams, MotionPlanner};
use pulsetrack_control::pd::gravity::{ArmGravity, Instrument};
use pulsetrack_control::pd::{GravityModel, PdController, PdParams, PhantomGravity, PhantomMasses};
use pulsetrack_control::types::{JointSetpoint, JointState, JointTorques};

const BATCHES: usize = 31;
const CALLS: usize = 20_000;

fn median_ns(mut f: impl FnMut(usize)) -> f64 {
    let mut per_call: Vec<f64> = (0..BATCHES)
        .map(|_| {
            let start = Instant::now();
            for i in 0..CALLS {
                f(i);
            }
            start.elapsed().as_secs_f64() * 1e9 / CALLS as f64
        })
        .collect();
    per_call.sort_by(f64::total_cmp);
    per_call[BATCHES / 2]
}

fn main() {
    let pivot = PivotGeometry::default();
    let arm = ArmModel::new(
        PhantomGeometry::default(),
        JointLimits::default(),
        pivot,
        tissue_under_pivot(
            &pivot,
            DEFAULT_SENSOR_OFFSET_M,
            DEFAULT_SURFACE_DEPTH_M,
            0.0,
        ),
        DEFAULT_SENSOR_OFFSET_M,
    )
    .expect("default geometry");
    let geom = PhantomGeometry::default();
    let points: Vec<Point3<f64>> = (0..64)
        .map(|i| {
            let a = f64::from(i) * 0.7;
            Point3::new(0.12 * a.sin(), -0.003, 0.06 * (1.3 * a).cos())
        })
        .collect();
    let joints: Vec<_> = points
        .iter()
        .map(|p| arm.joints_for_sensor(p).expect("reachable"))
        .collect();
    let gimbals: Vec<_> = joints
        .iter()
        .map(|q| phantom::forward(&geom, q).expect("finite"))
        .collect();
    let v = Vector3::new(0.02, 0.0, -0.01);
    let gravity = PhantomGravity::new(&PhantomMasses::default());
    // The seed's rig with 0.6 kg on the shaft against its 0.3 kg contact load (the config's
    // limit would refuse it, but the cost per call does not depend on the weight).
    let heavy = Instrument {
        mass_kg: 0.6,
        contact_load_n: 0.3 * 9.81,
    };
    // The shipped sim config's rod (the seed's bench).
    let rod = RodMechanics {
        bending_stiffness_nm2: 4.03,
        pivot_stiffness_n_per_m: 1000.0,
        rod_mass_kg: 0.062,
        tip_mass_kg: 0.3,
        tip_mass_height_m: 0.03,
    };
    let bare = ArmGravity::new(&PhantomMasses::default(), &geom, &pivot, None);
    let with_instrument = ArmGravity::new(&PhantomMasses::default(), &geom, &pivot, Some(&heavy));
    // A finished move whose arm stalled 3 mm short: undecided (judging and trimming every
    // call) for the settling time; and one already decided.
    let mut stalled = MotionPlanner::new(MotionParams::default()).expect("default motion");
    let target = SurfacePoint::new(0.01, 0.0);
    stalled
        .start(SurfacePoint::new(0.0, 0.0), target, 0.01, 0.0)
        .expect("valid move");
    let finish = stalled.finish_time_s().expect("a move");
    let short = SurfacePoint::new(0.007, 0.0);
    let mut decided = stalled.clone();
    decided.observe(target, 0.0, finish);
    let mut pd = PdController::new(PdParams::default()).expect("default gains");
    let mut planner = MotionPlanner::new(MotionParams::default()).expect("default motion");
    planner
        .start(
            SurfacePoint::new(-0.1, 0.0),
            SurfacePoint::new(0.1, 0.03),
            0.03,
            0.0,
        )
        .expect("valid move");

    // The joint stop sweep: joint 0 searching toward its lower stop (past the plan's first,
    // empty move), and a plan whose first move ramps θ3 (θ2's lower sweep from θ3 = 0.5 rad).
    let sweep_settings = JointSettings::default();
    let limits = JointLimits::default();
    let at = |q: [f64; 3], t: f64| JointState {
        t_s: t,
        position_rad: q,
        velocity_rad_s: [0.0; 3],
    };
    let mut searching = JointSweep::new(
        SweepPlan::new(
            &[0.0; 3],
            StopTargets::joints(&[0]).expect("joint 0"),
            &limits,
            &sweep_settings,
        )
        .expect("plan"),
        limits,
        sweep_settings,
    );
    searching
        .step(&at([0.0; 3], 0.0), &JointTorques::ZERO)
        .expect("the empty first move arrives");
    let moving_start = [0.0, 0.0, 0.5];
    let moving = JointSweep::new(
        SweepPlan::new(
            &moving_start,
            StopTargets::joints(&[1]).expect("joint 1"),
            &limits,
            &sweep_settings,
        )
        .expect("plan"),
        limits,
        sweep_settings,
    );
    let mut moving_now = moving;
    let pd_ns = median_ns(|i| {
        let q = joints[i % 64];
        let sp = JointSetpoint::at_rest(q);
        let st = JointState {
            t_s: 0.0,
            position_rad: q,
            velocity_rad_s: [0.0; 3],
        };
        black_box(pd.step(black_box(&sp), &st, &[0.0; 3], 1e-3).ok());
    });
    let rows: Vec<(&str, f64)> = vec![
        (
            "phantom::forward",
            median_ns(|i| {
                black_box(phantom::forward(&geom, black_box(&joints[i % 64])).ok());
            }),
        ),
        (
            "phantom::inverse",
            median_ns(|i| {
                black_box(phantom::inverse(&geom, black_box(&gimbals[i % 64])).ok());
            }),
        ),
        (
            "ArmModel::sensor_from_joints",
            median_ns(|i| {
                black_box(arm.sensor_from_joints(black_box(&joints[i % 64])).ok());
            }),
        ),
        (
            "ArmModel::joints_for_sensor",
            median_ns(|i| {
                black_box(arm.joints_for_sensor(black_box(&points[i % 64])).ok());
            }),
        ),
        (
            "ArmModel::sensor_jacobian",
            median_ns(|i| {
                black_box(arm.sensor_jacobian(black_box(&joints[i % 64])).ok());
            }),
        ),
        (
            "ArmModel::joint_setpoint",
            median_ns(|i| {
                black_box(arm.joint_setpoint(black_box(&points[i % 64]), &v).ok());
            }),
        ),
        (
            // Once per tactile frame (every tenth cycle at 100 Hz), with the config's `rod`:
            // the rod's load read from the motors' torque, through the gimbal Jacobian.
            "ArmModel::sensor_felt + PhantomGravity::torque_nm",
            median_ns(|i| {
                let q = black_box(&joints[i % 64]);
                let body = gravity.torque_nm(q);
                let motor = [body[0] + 0.05, body[1] - 0.1, body[2] + 0.08];
                black_box(arm.sensor_felt(q, &motor, &body, &rod, 9.81).ok());
            }),
        ),
        (
            "PhantomGravity::torque_nm",
            median_ns(|i| {
                black_box(gravity.torque_nm(black_box(&joints[i % 64])));
            }),
        ),
        (
            "ArmGravity::torque_nm, no instrument",
            median_ns(|i| {
                black_box(bare.torque_nm(black_box(&joints[i % 64])));
            }),
        ),
        (
            "ArmGravity::torque_nm, instrument",
            median_ns(|i| {
                black_box(with_instrument.torque_nm(black_box(&joints[i % 64])));
            }),
        ),
        (
            "MotionPlanner::observe, undecided (judge + trim)",
            median_ns(|i| {
                let t = finish + 0.1 + (i % 1000) as f64 * 1e-6;
                black_box(stalled.observe(black_box(short), 0.0, t));
            }),
        ),
        (
            "MotionPlanner::observe, decided",
            median_ns(|i| {
                let t = finish + 0.1 + (i % 1000) as f64 * 1e-6;
                black_box(decided.observe(black_box(short), 0.0, t));
            }),
        ),
        (
            "MotionPlanner::setpoint",
            median_ns(|i| {
                black_box(planner.setpoint(black_box(i as f64 * 1e-4)));
            }),
        ),
        ("PdController::step", pd_ns),
        (
            "one cycle: setpoint + joint_setpoint + gravity + PD",
            median_ns(|i| {
                let (p, vel) = planner.setpoint(i as f64 * 1e-4).expect("running");
                let sp = arm.joint_setpoint(&p, &vel).expect("reachable");
                let g = gravity.torque_nm(&sp.position_rad);
                let st = JointState {
                    t_s: 0.0,
                    position_rad: sp.position_rad,
                    velocity_rad_s: sp.velocity_rad_s,
                };
                black_box(pd.step(&sp, &st, &g, 1e-3).ok());
            }),
        ),
        (
            "one cycle + observe + instrument gravity",
            median_ns(|i| {
                let t = i as f64 * 1e-4;
                let (p, vel) = planner.setpoint(t).expect("running");
                let sp = arm.joint_setpoint(&p, &vel).expect("reachable");
                let now = SurfacePoint::new(p.x, p.z);
                black_box(planner.observe(now, 0.0, t));
                let g = with_instrument.torque_nm(&sp.position_rad);
                let st = JointState {
                    t_s: 0.0,
                    position_rad: sp.position_rad,
                    velocity_rad_s: sp.velocity_rad_s,
                };
                black_box(pd.step(&sp, &st, &g, 1e-3).ok());
            }),
        ),
        (
            "JointSweep::step, searching + cap + limits",
            median_ns(|i| {
                let t = 1e-3 + (i % 1000) as f64 * 1e-4;
                let c = searching.step(&at([-0.01, 0.0, 0.0], t), &JointTorques::ZERO);
                let capped = searching.cap(&JointTorques {
                    torque_nm: [0.2, -0.2, 0.1],
                });
                black_box((c.ok(), capped, searching.limits().min_rad[0]));
            }),
        ),
        (
            "JointSweep::step, moving + cap + limits",
            median_ns(|i| {
                if i == 0 {
                    moving_now = moving;
                }
                let t = (i % 1000) as f64 * 1e-4;
                let c = moving_now.step(&at(moving_start, t), &JointTorques::ZERO);
                let capped = moving_now.cap(&JointTorques {
                    torque_nm: [0.2, -0.2, 0.1],
                });
                black_box((c.ok(), capped, moving_now.limits().min_rad[0]));
            }),
        ),
        (
            "calibration::through_zero (the homing's offsets, every cycle)",
            median_ns(|i| {
                let mut q = joints[i % 64];
                through_zero(&mut q, black_box(&[0.001, -0.0349, 0.0002]));
                black_box(q);
            }),
        ),
        (
            "one sweep cycle: JointSweep::step + gravity + PD + cap",
            median_ns(|i| {
                let t = 1e-3 + (i % 1000) as f64 * 1e-4;
                let st = at([-0.01, 0.0, 0.0], t);
                let c = searching.step(&st, &JointTorques::ZERO).expect("searching");
                let g = gravity.torque_nm(&st.position_rad);
                let tau = pd.step(&c.setpoint, &st, &g, 1e-3).expect("finite");
                black_box(searching.cap(&tau));
            }),
        ),
    ];
    println!("{:<52} {:>10} {:>8}", "call", "median ns", "x PD");
    for (name, ns) in rows {
        println!("{name:<52} {ns:>10.1} {:>8.2}", ns / pd_ns);
    }
}
