//! The sweep plan against the Phantom's limits and coupling, and the whole sweep run cycle by
//! cycle against three joints with hard stops (unit-ish inertia, viscous friction, a PD law
//! capped as the loop caps it): every stop found where it is, the limits widened for the
//! swept joint only, the coupling kept, and a stopped sweep going straight home.

use super::joint_sweep::{JointSweep, OVERSHOOT_SLACK_RAD, SweepCycle};
use super::joints::{JointSettings, Side, StopFound};
use super::sweep_plan::{Leg, PLAN_MARGIN_RAD, PlanError, StopTargets, SweepPlan};
use crate::kinematics::JointLimits;
use crate::types::{JOINTS, JointState, JointTorques, Joints};

fn coupling_ok(q: &Joints, l: &JointLimits) -> bool {
    let c = q[2] - q[1];
    c >= l.coupling_min_rad && c <= l.coupling_max_rad
}

#[test]
fn the_plan_keeps_the_coupling_inside_its_range_over_every_sweep() {
    let l = JointLimits::default();
    let s = JointSettings::default();
    let plan = SweepPlan::new(&[0.0; 3], StopTargets::all(), &l, &s).expect("plan");
    assert_eq!(plan.legs().len(), 3 * 6 + 1);
    let mut upper3 = None;
    for leg in plan.legs() {
        if let Leg::Search { joint, side, hold } = *leg {
            let end = side.limit(&l, joint) + side.sign() * s.overtravel_rad;
            for q in [hold[joint], end] {
                let mut p = hold;
                p[joint] = q;
                assert!(
                    p[2] - p[1] >= l.coupling_min_rad + PLAN_MARGIN_RAD - 1e-12
                        && p[2] - p[1] <= l.coupling_max_rad - PLAN_MARGIN_RAD + 1e-12,
                    "{joint} {side:?}: {p:?}"
                );
            }
            if joint == 2 && side == Side::Upper {
                upper3 = Some(hold);
            }
        }
    }
    // From the reset pose θ3's upper stop needs θ2 raised first.
    let hold = upper3.expect("θ3 upper swept");
    assert!(hold[1] > 0.5, "{hold:?}");
    assert_eq!(
        plan.legs().last(),
        Some(&Leg::Move {
            to: [0.0; 3],
            widened: None
        })
    );
}

#[test]
fn the_plan_refuses_a_start_outside_the_limits_and_a_coupling_that_blocks() {
    let l = JointLimits::default();
    let s = JointSettings::default();
    let outside = SweepPlan::new(&[1.2, 0.0, 0.0], StopTargets::all(), &l, &s);
    assert!(
        matches!(outside, Err(PlanError::StartOutside { .. })),
        "{outside:?}"
    );
    assert!(SweepPlan::new(&[0.0; 3], StopTargets::default(), &l, &s).is_err());
    assert!(StopTargets::joints(&[3]).is_err());
    let narrow = JointLimits {
        coupling_max_rad: 0.2,
        ..l
    };
    let e = SweepPlan::new(
        &[0.0; 3],
        StopTargets::joints(&[2]).expect("2"),
        &narrow,
        &s,
    )
    .expect_err("θ3's upper stop cannot be reached");
    assert!(e.to_string().contains("joint 2's upper stop"), "{e}");
}

/// Three joints with hard stops, driven by a PD law through the sweep's cap.
struct Plant {
    q: Joints,
    qd: Joints,
    stops: [(f64, f64); 3],
}

impl Plant {
    fn step(&mut self, tau: &JointTorques, dt: f64) {
        for j in 0..JOINTS {
            self.qd[j] += (tau.torque_nm[j] - 0.05 * self.qd[j]) / 0.01 * dt;
            self.q[j] += self.qd[j] * dt;
            let (lo, hi) = self.stops[j];
            if self.q[j] <= lo || self.q[j] >= hi {
                self.q[j] = self.q[j].clamp(lo, hi);
                self.qd[j] = 0.0;
            }
        }
    }
}

struct Run {
    found: Vec<StopFound>,
    done: bool,
    worst_coupling_ok: bool,
    end: Joints,
}

/// Run `sweep` on `plant` for at most `t_max` s; `abort_at`: stop it then.
fn run(sweep: &mut JointSweep, plant: &mut Plant, t_max: f64, abort_at: Option<f64>) -> Run {
    let (dt, kp, kd) = (1e-3, [20.0; 3], [0.5; 3]);
    let mut tau = JointTorques::ZERO;
    let mut out = Run {
        found: Vec::new(),
        done: false,
        worst_coupling_ok: true,
        end: plant.q,
    };
    let limits = JointLimits::default();
    for k in 0..(t_max / dt) as usize {
        let t = k as f64 * dt;
        if abort_at.is_some_and(|a| t >= a) {
            sweep.abort();
        }
        let state = JointState {
            t_s: t,
            position_rad: plant.q,
            velocity_rad_s: plant.qd,
        };
        // The widened limits hold the arm: only the swept joint may leave the configured
        // range, and never by more than the overtravel and its slack.
        let w = sweep.limits();
        for j in 0..JOINTS {
            assert!(
                plant.q[j] >= w.min_rad[j] && plant.q[j] <= w.max_rad[j],
                "t {t}: joint {j} at {} outside {w:?}",
                plant.q[j]
            );
            let widened = w.min_rad[j] < limits.min_rad[j] || w.max_rad[j] > limits.max_rad[j];
            let settings = JointSettings::default();
            if widened {
                assert!(
                    w.min_rad[j]
                        >= limits.min_rad[j]
                            - settings.overtravel_rad
                            - OVERSHOOT_SLACK_RAD
                            - 1e-12
                );
            }
        }
        out.worst_coupling_ok &= coupling_ok(&plant.q, &limits);
        let SweepCycle {
            setpoint,
            found,
            done,
        } = sweep.step(&state, &tau).expect("sweep step");
        out.found.extend(found);
        if done {
            out.done = true;
            out.end = plant.q;
            return out;
        }
        let mut t_cmd = JointTorques::ZERO;
        for j in 0..JOINTS {
            t_cmd.torque_nm[j] = kp[j] * (setpoint.position_rad[j] - plant.q[j])
                + kd[j] * (setpoint.velocity_rad_s[j] - plant.qd[j]);
        }
        tau = sweep.cap(&t_cmd);
        plant.step(&tau, dt);
    }
    out.end = plant.q;
    out
}

#[test]
fn a_whole_sweep_finds_every_stop_and_comes_home() {
    let l = JointLimits::default();
    let s = JointSettings::default();
    // Joint 0's lower stop 30 mrad inside its limit; the rest 50 mrad outside.
    let mut stops = [0, 1, 2].map(|j| (l.min_rad[j] - 0.05, l.max_rad[j] + 0.05));
    stops[0].0 = l.min_rad[0] + 0.03;
    let mut plant = Plant {
        q: [0.0; 3],
        qd: [0.0; 3],
        stops,
    };
    let plan = SweepPlan::new(&plant.q, StopTargets::all(), &l, &s).expect("plan");
    let mut sweep = JointSweep::new(plan, l, s);
    let r = run(&mut sweep, &mut plant, 400.0, None);
    assert!(r.done, "the sweep did not finish: found {:?}", r.found);
    assert!(r.worst_coupling_ok, "the coupling left its range");
    assert_eq!(r.found.len(), 6, "{:?}", r.found);
    for f in &r.found {
        let (lo, hi) = stops[f.joint];
        let want = if f.side == Side::Lower { lo } else { hi };
        assert!(f.stalled, "{f:?}");
        assert!((f.at_rad - want).abs() < 1e-6, "{f:?} against {want}");
    }
    assert!(r.end.iter().all(|q| q.abs() < 0.011), "{:?}", r.end);
    let inside = r.found[0];
    assert!(inside.margin_rad(&l) < 0.0 && inside.joint == 0 && inside.side == Side::Lower);
}

#[test]
fn a_stopped_sweep_goes_straight_home_and_finds_nothing_more() {
    let l = JointLimits::default();
    let s = JointSettings::default();
    let stops = [0, 1, 2].map(|j| (l.min_rad[j] - 0.05, l.max_rad[j] + 0.05));
    let mut plant = Plant {
        q: [0.0; 3],
        qd: [0.0; 3],
        stops,
    };
    let plan =
        SweepPlan::new(&plant.q, StopTargets::joints(&[0]).expect("0"), &l, &s).expect("plan");
    let mut sweep = JointSweep::new(plan, l, s);
    let r = run(&mut sweep, &mut plant, 60.0, Some(4.0));
    assert!(r.done && sweep.aborted());
    assert!(r.found.is_empty(), "{:?}", r.found);
    assert!(r.end.iter().all(|q| q.abs() < 0.011), "{:?}", r.end);
}

#[test]
fn a_blocked_move_is_an_error_naming_the_joint() {
    let l = JointLimits::default();
    let s = JointSettings::default();
    // θ2's lower sweep from θ3 = 0.5 rad needs θ3 lowered first (the coupling at θ2's
    // overtravel end); the arm will not move, so that move never arrives.
    let start = [0.0, 0.0, 0.5];
    let plan = SweepPlan::new(&start, StopTargets::joints(&[1]).expect("1"), &l, &s).expect("plan");
    let mut sweep = JointSweep::new(plan, l, s);
    let mut err = None;
    for k in 0..200_000 {
        let state = JointState {
            t_s: k as f64 * 1e-3,
            position_rad: start,
            velocity_rad_s: [0.0; 3],
        };
        if let Err(e) = sweep.step(&state, &JointTorques::ZERO) {
            err = Some(e);
            break;
        }
    }
    let e = err.expect("blocked");
    assert!(e.to_string().contains("joint 2 did not reach"), "{e}");
}
