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

/// The loop's log while `f` runs on this thread, one string per line.
fn logged_lines(f: impl FnOnce()) -> Vec<String> {
    use std::sync::{Arc, Mutex};
    #[derive(Clone, Default)]
    struct Captured(Arc<Mutex<Vec<u8>>>);
    impl std::io::Write for Captured {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().expect("log buffer").extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let captured = Captured::default();
    let writer = captured.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_ansi(false)
        .with_max_level(tracing::Level::INFO)
        .finish();
    tracing::subscriber::with_default(subscriber, f);
    let bytes = captured.0.lock().expect("log buffer").clone();
    String::from_utf8_lossy(&bytes)
        .lines()
        .map(str::to_string)
        .collect()
}

const ESTOP_CAUSE: &str = "e-stop open on joint 2 (node 3); release it first";

fn refusal_text(e: &ControlEvent) -> String {
    match e {
        ControlEvent::Refused { why, .. } => why.describe(),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

/// The arm latches a fault of its own (a driver's e-stop) while powered.
fn arm_latched_while_enabled() -> plant::Rig {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    r.run(100);
    r.knobs.lock().expect("knobs").arm_cause = Some(ESTOP_CAUSE.into());
    r.run(5);
    assert_eq!(r.faults(), vec![FaultKind::Backend]);
    assert_eq!(r.status().mode, LoopMode::Faulted);
    r
}

#[test]
fn reset_after_an_arm_fault_names_the_cause_then_clears_it_once_gone() {
    let mut r = arm_latched_while_enabled();
    // The cause persists: refused after the wait, in the arm's own words (was "the cause is
    // still present: joint stale", for ever, because a latched arm gives no joint data).
    let e = r.send(|seq| ControlCommand::Reset { seq });
    let why = refusal_text(&e);
    assert_eq!(why, format!("the cause is still present: {ESTOP_CAUSE}"));
    assert!(
        r.cycles_to_answer > 200,
        "waited for the cause to clear: {} cycles",
        r.cycles_to_answer
    );
    assert_eq!(r.status().mode, LoopMode::Faulted);
    // Released: one reset clears the arm's latch and the loop's, leaves it unpowered.
    r.knobs.lock().expect("knobs").arm_cause = None;
    let e = r.send(|seq| ControlCommand::Reset { seq });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    assert_eq!(r.cycles_to_answer, 1, "answered at once");
    assert!(!r.knobs.lock().expect("knobs").arm_latched);
    r.run(100);
    let s = r.status();
    assert_eq!(s.mode, LoopMode::Disabled);
    assert_eq!(s.torque_nm, [0.0; 3]);
    let e = r.send(|seq| ControlCommand::Enable { seq });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    r.run(200);
    assert_eq!(r.status().mode, LoopMode::Enabled);
    assert!(r.faults().is_empty());
}

#[test]
fn a_reset_sent_while_the_cause_is_present_succeeds_if_it_clears_within_the_wait() {
    let mut r = arm_latched_while_enabled();
    r.seq += 1;
    let seq = r.seq;
    r.commands
        .try_send(ControlCommand::Reset { seq })
        .expect("queue");
    r.run(50);
    assert!(r.events.try_recv().is_err(), "not answered yet");
    r.knobs.lock().expect("knobs").arm_cause = None;
    r.run(1);
    match r.events.try_recv() {
        Ok(ControlEvent::Done { seq: s, .. }) => assert_eq!(s, seq),
        other => panic!("{other:?}"),
    }
    assert_eq!(r.status().mode, LoopMode::Disabled);
}

#[test]
fn an_arm_latched_while_unpowered_shows_as_a_fault_that_reset_clears() {
    let mut r = rig();
    r.run(50);
    // Latched while disabled (a bus lost with the arm unpowered): the arm refuses the
    // loop's zero torques, so the loop latches too and the operator sees a fault.
    r.knobs.lock().expect("knobs").arm_cause = Some(ESTOP_CAUSE.into());
    r.run(5);
    assert_eq!(r.faults(), vec![FaultKind::Backend]);
    let e = r.send(|seq| ControlCommand::Reset { seq });
    assert_eq!(
        refusal_text(&e),
        format!("the cause is still present: {ESTOP_CAUSE}")
    );
    r.knobs.lock().expect("knobs").arm_cause = None;
    let e = r.send(|seq| ControlCommand::Reset { seq });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    let e = r.send(|seq| ControlCommand::Enable { seq });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
}

#[test]
fn a_latched_arm_is_logged_once_per_burst_not_every_cycle() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    r.run(100);
    let lines = logged_lines(|| {
        // 3 s of the loop's clock with every read and write refused.
        r.knobs.lock().expect("knobs").arm_cause = Some(ESTOP_CAUSE.into());
        r.run(3000);
        assert_eq!(r.status().mode, LoopMode::Faulted);
        r.knobs.lock().expect("knobs").arm_cause = None;
        assert!(matches!(
            r.send(|seq| ControlCommand::Reset { seq }),
            ControlEvent::Done { .. }
        ));
        // The burst ends 2 s after the last refusal and its count is logged.
        r.run(2500);
    });
    let text = lines.join("\n");
    // Was one ERROR line a cycle: 3000 here. Now the start and the end of each burst
    // (reads: one, before the loop latched; writes: every cycle).
    assert!(lines.len() <= 4, "{} lines:\n{text}", lines.len());
    assert!(
        lines.iter().any(|l| l.contains("writing torques failed")
            && l.contains("further ones are counted")),
        "{text}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.contains("writing torques failed: burst over")),
        "the count is logged when the burst ends:\n{text}"
    );
}

#[test]
fn after_reset_the_setpoint_is_the_measured_pose() {
    let mut r = rig();
    r.run(50);
    r.send(|seq| ControlCommand::Enable { seq });
    let target = SurfacePoint::new(r.start.x_m + 0.01, r.start.z_m);
    r.send(|seq| ControlCommand::MoveTo {
        seq,
        target,
        speed_m_s: 0.01,
    });
    // Mid-move, the estop: the setpoint was ahead of the arm.
    r.run(400);
    r.send(|seq| ControlCommand::Estop { seq });
    r.run(200);
    let before = r.status();
    assert_eq!(before.mode, LoopMode::Faulted);
    assert!(
        before.setpoint.distance_to(&before.sensor) > 0.0,
        "the test needs a setpoint away from the arm"
    );
    let e = r.send(|seq| ControlCommand::Reset { seq });
    assert!(matches!(e, ControlEvent::Done { .. }), "{e:?}");
    let s = r.status();
    assert_eq!(s.mode, LoopMode::Disabled);
    // Was the setpoint of the interrupted move.
    assert_eq!(s.setpoint, s.sensor, "{s:?}");
    assert_eq!(s.setpoint_rad, s.position_rad, "{s:?}");
}
