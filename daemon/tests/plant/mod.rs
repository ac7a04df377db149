//! A small physical test double of the ports for the control loop: three joint inertias with
//! damping and the gravity torques the PD compensates, and a tactile array pressing with a set
//! force; plus a rig that steps the real loop one cycle at a time on the double's clock.

#![allow(dead_code)]

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
pub use pulsetrack_daemon::rt::fault::FaultKind;
use pulsetrack_daemon::rt::flight_recorder::FlightRecorder;
pub use pulsetrack_daemon::rt::link::{
    ControlCommand, ControlEvent, ControlStatus, LoopMode, LoopSample,
};
use pulsetrack_daemon::rt::safety::SafetyLimits;
use pulsetrack_daemon::slot::Slot;

pub const DT: f64 = 0.001;

/// What the test can change while the loop runs.
#[derive(Debug, Default)]
pub struct Knobs {
    pub force_per_element_n: f64,
    pub nan_joints: bool,
    /// A fault in the arm itself (a driver's latch: e-stop, lost bus) whose cause is
    /// present, in the driver's words: the arm latches it and refuses reads and writes.
    pub arm_cause: Option<String>,
    /// The arm's latch: set by a cause, cleared only by `recover` once the cause is gone.
    pub arm_latched: bool,
}

impl Knobs {
    /// The arm's latch after looking at the cause, like a driver servicing its bus.
    fn latched(&mut self) -> bool {
        if self.arm_cause.is_some() {
            self.arm_latched = true;
        }
        self.arm_latched
    }
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
        if self.knobs.lock().map(|mut k| k.latched()).unwrap_or(false) {
            return Err(PortError("arm faulted".into()));
        }
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
    fn recover(&mut self) -> Result<(), PortError> {
        let mut k = self.knobs.lock().expect("knobs");
        if let Some(cause) = &k.arm_cause {
            return Err(PortError(cause.clone()));
        }
        k.arm_latched = false;
        Ok(())
    }
    fn write_torques(&mut self, t: &JointTorques) -> Result<(), PortError> {
        let latched = self.knobs.lock().map(|mut k| k.latched()).unwrap_or(false);
        if latched {
            self.enabled = false;
        }
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
        if latched {
            // The clock still advances: a latched rig refuses the command, not time.
            return Err(PortError("arm faulted: torque refused".into()));
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

pub struct Rig {
    pub control: ControlLoop,
    pub commands: Sender<ControlCommand>,
    pub events: Receiver<ControlEvent>,
    pub samples: Receiver<LoopSample>,
    pub status: Arc<Slot<ControlStatus>>,
    pub knobs: Arc<Mutex<Knobs>>,
    pub seq: u64,
    pub start: SurfacePoint,
    pub cycles_to_answer: usize,
}

fn config() -> Config {
    let (name, text) = config::shipped::SIM_CONFIG;
    config::load_str::<Config>(name, text).expect("shipped config")
}

pub fn rig() -> Rig {
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
        ..Knobs::default()
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
        samples: s_rx,
        status,
        knobs,
        seq: 0,
        start,
        cycles_to_answer: 0,
    }
}

impl Rig {
    pub fn run(&mut self, cycles: usize) {
        for _ in 0..cycles {
            self.control.cycle();
        }
    }
    pub fn status(&self) -> ControlStatus {
        self.status.read().expect("status")
    }
    /// Send a command and run until it is answered: in the cycle that takes it, or, for a
    /// reset waiting for its cause to clear, within the loop's wait (0.25 s). The cycles
    /// run meanwhile are counted in [`Self::cycles_to_answer`].
    pub fn send(&mut self, f: impl FnOnce(u64) -> ControlCommand) -> ControlEvent {
        self.seq += 1;
        let seq = self.seq;
        self.commands.try_send(f(seq)).expect("queue");
        for cycles in 1..=1000 {
            self.run(1);
            while let Ok(e) = self.events.try_recv() {
                match e {
                    ControlEvent::Done { seq: s, .. } | ControlEvent::Refused { seq: s, .. }
                        if s == seq =>
                    {
                        self.cycles_to_answer = cycles;
                        return e;
                    }
                    _ => {}
                }
            }
        }
        panic!("no answer to command {seq} in 1000 cycles");
    }
    pub fn faults(&self) -> Vec<FaultKind> {
        self.events
            .try_iter()
            .filter_map(|e| match e {
                ControlEvent::Faulted(f) => Some(f.kind),
                _ => None,
            })
            .collect()
    }
}
