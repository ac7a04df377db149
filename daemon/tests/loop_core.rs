//! The control loop with the real servo (ArmModel, MotionPlanner, PD with gravity) on a small
//! test double of the ports: three independent joint inertias with damping and the same
//! gravity torques the PD compensates, and a tactile array pressing with a set force.
//! The loop is stepped directly, one cycle at a time, on the double's clock.

mod plant;

use control::frames::SurfacePoint;
use plant::{ControlCommand, ControlEvent, FaultKind, LoopMode, rig};

#[test]
fn enabling_holds_where_the_arm_is_without_a_jump() {
    let mut r = rig();
    r.run(100);
    let before = r.status();
    assert_eq!(before.mode, LoopMode::Disabled);
    assert!(matches!(
        r.send(|seq| ControlCommand::Enable { seq }),
        ControlEvent::Done { .. }
    ));
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        r.run(1);
        let s = r.status();
        for i in 0..3 {
            worst = worst.max((s.position_rad[i] - before.position_rad[i]).abs());
        }
    }
    assert!(worst < 2e-3, "moved {worst} rad on enable");
    assert!(r.status().sensor.distance_to(&r.start) < 1e-3);
    assert!(r.faults().is_empty());
}

#[test]
fn a_move_arrives_settles_and_only_then_says_so() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    let target = SurfacePoint::new(r.start.x_m + 0.01, r.start.z_m - 0.004);
    let e = r.send(|seq| ControlCommand::MoveTo {
        seq,
        target,
        speed_m_s: 0.01,
    });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    let seq = r.seq;
    r.run(200);
    assert!(!r.status().settled, "settled in the middle of a 1 s move");
    r.run(4000);
    let s = r.status();
    assert_eq!(s.motion_seq, seq);
    assert!(s.settled);
    assert!(
        s.sensor.distance_to(&target) < 1.5e-3,
        "ended {:?}",
        s.sensor
    );
    assert!(r.faults().is_empty());
}

#[test]
fn targets_outside_the_workspace_are_refused_and_nothing_moves() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    let e = r.send(|seq| ControlCommand::MoveTo {
        seq,
        target: SurfacePoint::new(0.5, 0.0),
        speed_m_s: 0.01,
    });
    assert!(matches!(e, ControlEvent::Refused { .. }), "{e:?}");
    r.run(500);
    assert!(r.status().sensor.distance_to(&r.start) < 1e-3);
    assert_eq!(r.status().mode, LoopMode::Enabled);
}

#[test]
fn excess_contact_force_faults_powers_off_and_drops_queued_commands() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    r.run(100);
    r.knobs.lock().expect("knobs").force_per_element_n = 5.0; // 50 N in all
    for s in 1..=3 {
        r.commands
            .try_send(ControlCommand::MoveTo {
                seq: 100 + s,
                target: SurfacePoint::new(0.01, 0.0),
                speed_m_s: 0.01,
            })
            .expect("queue");
    }
    r.run(20);
    assert_eq!(r.status().mode, LoopMode::Faulted);
    let events: Vec<ControlEvent> = r.events.try_iter().collect();
    assert!(
        events
            .iter()
            .any(|e| matches!(e, ControlEvent::Faulted(f) if f.kind == FaultKind::ContactForce))
    );
    // Torque is off from the fault on, and nothing resumes by itself.
    r.knobs.lock().expect("knobs").force_per_element_n = 0.2;
    r.run(500);
    let s = r.status();
    assert_eq!(s.mode, LoopMode::Faulted);
    assert_eq!(s.torque_nm, [0.0; 3]);
    let e = r.send(|seq| ControlCommand::Enable { seq });
    assert!(matches!(e, ControlEvent::Refused { .. }), "{e:?}");
    assert!(matches!(
        r.send(|seq| ControlCommand::Reset { seq }),
        ControlEvent::Done { .. }
    ));
    assert_eq!(r.status().mode, LoopMode::Disabled);
}

#[test]
fn non_finite_joint_data_faults_and_blocks_reset_until_it_clears() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    r.run(10);
    r.knobs.lock().expect("knobs").nan_joints = true;
    r.run(2);
    assert_eq!(r.faults(), vec![FaultKind::NonFiniteJoints]);
    assert!(matches!(
        r.send(|seq| ControlCommand::Reset { seq }),
        ControlEvent::Refused { .. }
    ));
    r.knobs.lock().expect("knobs").nan_joints = false;
    assert!(matches!(
        r.send(|seq| ControlCommand::Reset { seq }),
        ControlEvent::Done { .. }
    ));
    assert!(matches!(
        r.send(|seq| ControlCommand::Enable { seq }),
        ControlEvent::Done { .. }
    ));
}

#[test]
fn an_estop_drops_every_queued_command() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    r.commands
        .try_send(ControlCommand::Estop { seq: 50 })
        .expect("queue");
    for s in 51..=53 {
        r.commands
            .try_send(ControlCommand::MoveTo {
                seq: s,
                target: SurfacePoint::new(0.01, 0.0),
                speed_m_s: 0.01,
            })
            .expect("queue");
    }
    r.run(1);
    let events: Vec<ControlEvent> = r.events.try_iter().collect();
    assert!(
        events
            .iter()
            .any(|e| matches!(e, ControlEvent::Faulted(f) if f.kind == FaultKind::Estop))
    );
    for s in 51..=53 {
        assert!(
            events
                .iter()
                .any(|e| matches!(e, ControlEvent::Refused { seq, .. } if *seq == s)),
            "queued move {s} not dropped: {events:?}"
        );
    }
    r.run(100);
    assert_eq!(r.status().torque_nm, [0.0; 3]);
}
