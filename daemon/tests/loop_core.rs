//! The control loop with the real servo (ArmModel, MotionPlanner, PD with gravity) on a small
//! test double of the ports: three independent joint inertias with damping and the same
//! gravity torques the PD compensates, and a tactile array pressing with a set force.
//! The loop is stepped directly, one cycle at a time, on the double's clock.

use std::sync::{Arc, Mutex};

use config::Config;
use control::frames::SurfacePoint;
use control::pd::{GravityModel, PhantomGravity};
use control::types::{JointState, JointTorques, Joints, TactileFrame};
use crossbeam_channel::{Receiver, Sender};
use nalgebra::Point3;
use pulsetrack_daemon::backend::{ArmPort, PortError, TactilePort};
use pulsetrack_daemon::rt::control_loop::{ControlLoop, LoopLinks};
use pulsetrack_daemon::rt::core_servo::CoreServo;
use pulsetrack_daemon::rt::fault::FaultKind;
use pulsetrack_daemon::rt::flight_recorder::FlightRecorder;
use pulsetrack_daemon::rt::link::{
    ControlCommand, ControlEvent, ControlStatus, LoopMode, LoopSample,
};
use pulsetrack_daemon::rt::safety::SafetyLimits;
use pulsetrack_daemon::slot::Slot;

const DT: f64 = 0.001;

/// What the test can change while the loop runs.
#[derive(Debug, Default)]
struct Knobs {
    force_per_element_n: f64,
    nan_joints: bool,
}

struct Plant {
    t: f64,
    q: Joints,
    qd: Joints,
    enabled: bool,
    gravity: PhantomGravity,
    frames: Sender<TactileFrame>,
    knobs: Arc<Mutex<Knobs>>,
    steps: u64,
}

impl ArmPort for Plant {
    fn enable(&mut self) -> Result<(), PortError> {
        self.enabled = true;
        Ok(())
    }
    fn disable(&mut self) -> Result<(), PortError> {
        self.enabled = false;
        Ok(())
    }
    fn read_joints(&mut self) -> Result<JointState, PortError> {
        let nan = self.knobs.lock().map(|k| k.nan_joints).unwrap_or(false);
        let mut q = self.q;
        if nan {
            q[1] = f64::NAN;
        }
        Ok(JointState {
            t_s: self.t,
            position_rad: q,
            velocity_rad_s: self.qd,
        })
    }
    fn write_torques(&mut self, t: &JointTorques) -> Result<(), PortError> {
        // Powered: torque against gravity; unpowered: the arm is held (resting on tissue).
        if self.enabled {
            let g = self.gravity.torque_nm(&self.q);
            #[allow(clippy::needless_range_loop)]
            for i in 0..3 {
                let inertia = 0.01;
                let acc = (t.torque_nm[i] - g[i] - 0.02 * self.qd[i]) / inertia;
                self.qd[i] += acc * DT;
                self.q[i] += self.qd[i] * DT;
            }
        } else {
            self.qd = [0.0; 3];
        }
        self.t += DT;
        self.steps += 1;
        if self.steps.is_multiple_of(10) {
            let f = self
                .knobs
                .lock()
                .map(|k| k.force_per_element_n)
                .unwrap_or(0.0);
            let _ = self.frames.try_send(TactileFrame {
                t_s: self.t,
                seq: self.steps / 10,
                force_n: [f; 10],
            });
        }
        Ok(())
    }
    fn now_s(&self) -> f64 {
        self.t
    }
}

struct Array(Receiver<TactileFrame>);

impl TactilePort for Array {
    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, PortError> {
        Ok(self.0.try_recv().ok())
    }
}

struct Rig {
    control: ControlLoop,
    commands: Sender<ControlCommand>,
    events: Receiver<ControlEvent>,
    _samples: Receiver<LoopSample>,
    status: Arc<Slot<ControlStatus>>,
    knobs: Arc<Mutex<Knobs>>,
    seq: u64,
    start: SurfacePoint,
}

fn config() -> Config {
    let (name, text) = config::shipped::SIM_CONFIG;
    config::load_str::<Config>(name, text).expect("shipped config")
}

fn rig() -> Rig {
    let c = config();
    let arm = c.robot.arm_model().expect("arm model");
    let start = SurfacePoint::new(0.0, 0.0);
    let q0 = arm
        .joints_for_sensor(&Point3::new(
            start.x_m,
            c.control.motion.contact_height_m,
            start.z_m,
        ))
        .expect("reachable start");
    let (ftx, frx) = crossbeam_channel::bounded(1024);
    let knobs = Arc::new(Mutex::new(Knobs {
        force_per_element_n: 0.2,
        nan_joints: false,
    }));
    let plant = Plant {
        t: 0.0,
        q: q0,
        qd: [0.0; 3],
        enabled: false,
        gravity: PhantomGravity::new(&c.robot.link_masses),
        frames: ftx,
        knobs: Arc::clone(&knobs),
        steps: 0,
    };
    let (cmd_tx, cmd_rx) = crossbeam_channel::bounded(64);
    let (ev_tx, ev_rx) = crossbeam_channel::bounded(4096);
    let (s_tx, s_rx) = crossbeam_channel::bounded(1 << 20);
    let status = Arc::new(Slot::new());
    let control = ControlLoop::new(
        Box::new(plant),
        Box::new(Array(frx)),
        Box::new(CoreServo::new(&c).expect("servo")),
        SafetyLimits::from_config(&c),
        c.control.rate_hz,
        LoopLinks {
            commands: cmd_rx,
            events: ev_tx,
            samples: s_tx,
            status: Arc::clone(&status),
            flight: FlightRecorder::new(5000),
            joint_every: 10,
        },
    );
    Rig {
        control,
        commands: cmd_tx,
        events: ev_rx,
        _samples: s_rx,
        status,
        knobs,
        seq: 0,
        start,
    }
}

impl Rig {
    fn run(&mut self, cycles: usize) {
        for _ in 0..cycles {
            self.control.cycle();
        }
    }
    fn status(&self) -> ControlStatus {
        self.status.read().expect("status")
    }
    fn send(&mut self, f: impl FnOnce(u64) -> ControlCommand) -> ControlEvent {
        self.seq += 1;
        let seq = self.seq;
        self.commands.try_send(f(seq)).expect("queue");
        self.run(1);
        loop {
            match self.events.try_recv().expect("an answer") {
                e @ (ControlEvent::Done { seq: s, .. } | ControlEvent::Refused { seq: s, .. })
                    if s == seq =>
                {
                    return e;
                }
                _ => {}
            }
        }
    }
    fn faults(&self) -> Vec<FaultKind> {
        self.events
            .try_iter()
            .filter_map(|e| match e {
                ControlEvent::Faulted(f) => Some(f.kind),
                _ => None,
            })
            .collect()
    }
}

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
