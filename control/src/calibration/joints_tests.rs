//! The joints' calibration: the zero offsets and their checks, and the stop sweep against a
//! joint with a hard stop (a unit inertia with viscous friction, driven by a capped PD).

use super::joints::{JointSettings, Side, StopFound, through_zero, zero_checks, zero_offsets};
use super::stop_search::{SearchStep, StopSearch};
use super::tolerance::all_passed;
use crate::kinematics::JointLimits;
use crate::types::JointState;

#[test]
fn the_zero_offset_is_the_reset_pose_less_the_reading_and_is_judged_by_its_size() {
    let s = JointSettings::default();
    let reset = [0.0, 0.1, -0.2];
    let read = [0.0349, 0.1, -0.2];
    let o = zero_offsets(&reset, &read).expect("finite");
    assert!((o[0] + 0.0349).abs() < 1e-12 && o[1] == 0.0 && o[2] == 0.0);
    assert!(all_passed(&zero_checks(&o, &s)));
    let far = zero_offsets(&reset, &[0.5, 0.1, -0.2]).expect("finite");
    let checks = zero_checks(&far, &s);
    assert!(!checks[0].passed() && checks[1].passed());
    assert!(checks[0].quantity.contains("joint 0"));
    assert!(zero_offsets(&reset, &[f64::NAN, 0.0, 0.0]).is_err());
}

#[test]
fn settings_refuse_what_no_sweep_could_run_by() {
    assert!(JointSettings::default().check().is_ok());
    let bad = [
        JointSettings {
            sweep_speed_rad_s: 0.0,
            ..Default::default()
        },
        JointSettings {
            sweep_speed_rad_s: 2.0,
            ..Default::default()
        },
        JointSettings {
            sweep_torque_nm: [0.1, f64::NAN, 0.1],
            ..Default::default()
        },
        JointSettings {
            reset_pose_rad: [0.0, f64::INFINITY, 0.0],
            ..Default::default()
        },
        JointSettings {
            overtravel_rad: 0.01,
            min_stop_margin_rad: 0.02,
            ..Default::default()
        },
    ];
    for s in bad {
        assert!(s.check().is_err(), "{s:?} accepted");
    }
}

/// Sweep joint `joint` toward `side` with its stop at `stop_rad`; where the sweep ended.
fn sweep(joint: usize, side: Side, stop_rad: f64) -> StopFound {
    let s = JointSettings::default();
    let limits = JointLimits::default();
    let mut search = StopSearch::new(joint, side, 0.0, &limits, s).expect("valid");
    let (dt, kp, kd, cap) = (1e-3, 20.0, 0.5, s.sweep_torque_nm[joint]);
    let (mut q, mut qd, mut tau) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..200_000 {
        let mut state = JointState {
            t_s: k as f64 * dt,
            position_rad: [0.0; 3],
            velocity_rad_s: [0.0; 3],
        };
        state.position_rad[joint] = q;
        state.velocity_rad_s[joint] = qd;
        match search.step(&state, tau).expect("finite") {
            SearchStep::Found(f) => return f,
            SearchStep::Drive { setpoint_rad } => {
                tau = (kp * (setpoint_rad - q) - kd * qd).clamp(-cap, cap);
                // Unit-ish inertia and viscous friction; the stop clamps the motion.
                qd += (tau - 0.05 * qd) / 0.01 * dt;
                q += qd * dt;
                let beyond = side.sign() * (q - stop_rad);
                if beyond >= 0.0 {
                    q = stop_rad;
                    qd = 0.0;
                }
            }
        }
    }
    panic!("the sweep never ended");
}

#[test]
fn a_stop_outside_the_limit_by_the_margin_passes_and_one_inside_fails_naming_it() {
    let limits = JointLimits::default();
    let s = JointSettings::default();
    let out = sweep(1, Side::Upper, limits.max_rad[1] + 0.05);
    assert!(out.stalled);
    assert!(
        (out.at_rad - (limits.max_rad[1] + 0.05)).abs() < 1e-9,
        "{out:?}"
    );
    assert!(out.check(&limits, &s).expect("joint").passed());

    let inside = sweep(0, Side::Lower, limits.min_rad[0] + 0.03);
    assert!(inside.stalled);
    let c = inside.check(&limits, &s).expect("joint");
    assert!(!c.passed());
    assert!((c.value + 0.03).abs() < 1e-9, "{c:?}");
    assert!(c.quantity.contains("joint 0 lower"), "{}", c.quantity);
}

#[test]
fn a_joint_that_reaches_the_overtravel_freely_has_its_stop_further_out() {
    let limits = JointLimits::default();
    let s = JointSettings::default();
    let free = sweep(2, Side::Upper, 10.0);
    assert!(!free.stalled);
    let c = free.check(&limits, &s).expect("joint");
    assert!(c.passed() && c.value >= s.overtravel_rad - 1e-9, "{c:?}");
}

#[test]
fn a_sweep_refuses_a_joint_the_arm_does_not_have_and_non_finite_states() {
    let limits = JointLimits::default();
    let s = JointSettings::default();
    assert!(StopSearch::new(3, Side::Lower, 0.0, &limits, s).is_err());
    assert!(StopSearch::new(0, Side::Lower, f64::NAN, &limits, s).is_err());
    let mut search = StopSearch::new(0, Side::Lower, 0.0, &limits, s).expect("valid");
    let state = JointState {
        t_s: 0.0,
        position_rad: [f64::NAN, 0.0, 0.0],
        velocity_rad_s: [0.0; 3],
    };
    assert!(search.step(&state, 0.0).is_err());
    let bad = StopFound {
        joint: 7,
        side: Side::Upper,
        at_rad: 0.0,
        stalled: true,
    };
    assert!(bad.check(&limits, &s).is_err());
}

#[test]
fn the_encoders_read_through_the_measured_zero_give_the_reset_pose() {
    let reset = [0.0, 0.1, 0.5];
    let read = [0.0349, 0.1 - 0.002, 0.5];
    let offset = zero_offsets(&reset, &read).expect("finite");
    let mut q = read;
    through_zero(&mut q, &offset);
    for j in 0..3 {
        assert!((q[j] - reset[j]).abs() < 1e-15, "joint {j}: {q:?}");
    }
}
