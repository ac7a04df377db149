//! A small test double of the ports, the servo and a tracker, so the daemon's plumbing
//! (states, console, recording, faults) runs in process without the simulator.
//! The "arm" is a first-order plant whose joints 0 and 1 are the sensor's x and z in metres.

#![allow(dead_code)]

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use control::frames::SurfacePoint;
use control::tracker::{
    EndReason, LocatedPoint, MotionCommand, TrackLimit, Tracker, TrackerError, TrackerEvent,
    TrackerInput, TrackerOutput, TrackerPhase,
};
use control::types::{JointState, JointTorques, Joints, TactileFrame};
use crossbeam_channel::{Receiver, Sender};
use pulsetrack_daemon::backend::{ArmPort, Backend, BackendInfo, PortError, TactilePort};
use pulsetrack_daemon::rt::fault::Fault;
use pulsetrack_daemon::rt::link::Refusal;
use pulsetrack_daemon::rt::servo::{SensorPose, Servo, ServoStep};

pub const DT: f64 = 0.001;

pub struct FakeArm {
    t_s: f64,
    q: Joints,
    qd: Joints,
    enabled: bool,
    steps: u64,
    frames: Sender<TactileFrame>,
    seq: u64,
    /// Joint 0 (the sensor's x) cannot pass this: a stuck joint, a heavy instrument.
    wall_x_m: Option<f64>,
}

impl ArmPort for FakeArm {
    fn enable(&mut self) -> Result<(), PortError> {
        self.enabled = true;
        Ok(())
    }
    fn disable(&mut self) -> Result<(), PortError> {
        self.enabled = false;
        Ok(())
    }
    fn read_joints(&mut self) -> Result<JointState, PortError> {
        Ok(JointState {
            t_s: self.t_s,
            position_rad: self.q,
            velocity_rad_s: self.qd,
        })
    }
    fn write_torques(&mut self, t: &JointTorques) -> Result<(), PortError> {
        for i in 0..3 {
            self.qd[i] = if self.enabled {
                t.torque_nm[i] * 0.5
            } else {
                0.0
            };
            self.q[i] += self.qd[i] * DT;
        }
        if let Some(wall) = self.wall_x_m
            && self.q[0] > wall
        {
            self.q[0] = wall;
            self.qd[0] = 0.0;
        }
        self.t_s += DT;
        self.steps += 1;
        if self.steps.is_multiple_of(10) {
            self.seq += 1;
            let _ = self.frames.try_send(TactileFrame {
                t_s: self.t_s,
                seq: self.seq,
                force_n: [0.5; 10],
            });
        }
        Ok(())
    }
    fn now_s(&self) -> f64 {
        self.t_s
    }
}

pub struct FakeTactile(Receiver<TactileFrame>);

impl TactilePort for FakeTactile {
    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, PortError> {
        Ok(self.0.try_recv().ok())
    }
}

pub fn backend() -> Backend {
    backend_with_wall(None)
}

/// The double with joint 0 stopped at `wall_x_m`: moves beyond it stop short.
pub fn backend_with_wall(wall_x_m: Option<f64>) -> Backend {
    let (tx, rx) = crossbeam_channel::bounded(1024);
    Backend {
        arm: Box::new(FakeArm {
            t_s: 0.0,
            q: [0.0, 0.0, 0.2],
            qd: [0.0; 3],
            enabled: false,
            steps: 0,
            frames: tx,
            seq: 0,
            wall_x_m,
        }),
        tactile: Box::new(FakeTactile(rx)),
        info: BackendInfo {
            kind: "test-double",
            time_scale: 20.0,
            wall_clock_bound: false,
            scene: None,
        },
        judge: None,
        array_bench: None,
    }
}

/// Straight moves at constant speed; P control of joints 0 and 1 toward the setpoint.
#[derive(Default)]
pub struct FakeServo {
    setpoint: Option<SurfacePoint>,
    target: SurfacePoint,
    speed: f64,
    /// When the setpoint reached the target, for the settling time.
    finished_s: Option<f64>,
    /// Moves still to come that are reported as still moving at their settling deadline,
    /// and whether the current one is.
    restless_moves: u32,
    restless: bool,
}

impl FakeServo {
    /// The next `moves` moves never settle by themselves: at their settling deadline they
    /// are short of their target as not at rest, wherever the arm is. Holds settle.
    pub fn restless(moves: u32) -> Self {
        Self {
            restless_moves: moves,
            ..Self::default()
        }
    }
}

/// As control's default `settle_timeout_s`.
const SETTLE_TIMEOUT_S: f64 = 1.0;

impl Servo for FakeServo {
    fn sensor_pose(&self, _now: f64, q: &Joints) -> Result<SensorPose, Fault> {
        Ok(SensorPose {
            centre: SurfacePoint::new(q[0], q[1]),
            depth_m: q[2],
            height_m: 0.0,
        })
    }
    fn sensor_felt(&self, _q: &Joints, _torque: &Joints) -> Option<SurfacePoint> {
        None // no rod described
    }
    fn hold_here(&mut self, _now: f64, s: &JointState) -> Result<(), Fault> {
        let p = SurfacePoint::new(s.position_rad[0], s.position_rad[1]);
        self.setpoint = Some(p);
        self.target = p;
        self.finished_s = None;
        self.restless = false;
        Ok(())
    }
    fn move_to(&mut self, _now: f64, target: SurfacePoint, speed: f64) -> Result<(), Refusal> {
        if self.setpoint.is_none() {
            return Err(Refusal::NotEnabled);
        }
        self.target = target;
        self.speed = speed;
        self.finished_s = None;
        self.restless = self.restless_moves > 0;
        self.restless_moves = self.restless_moves.saturating_sub(1);
        Ok(())
    }
    fn hold(&mut self, _now: f64) {
        if let Some(p) = self.setpoint {
            self.target = p;
        }
        self.finished_s = None;
        self.restless = false;
    }
    fn step(&mut self, now: f64, s: &JointState, dt: f64) -> Result<ServoStep, Fault> {
        let sp = self
            .setpoint
            .ok_or_else(|| Fault::new(pulsetrack_daemon::rt::fault::FaultKind::Kinematics, now))?;
        let d = sp.distance_to(&self.target);
        let step = self.speed * dt;
        let next = if d <= step || d == 0.0 {
            self.target
        } else {
            SurfacePoint::new(
                sp.x_m + (self.target.x_m - sp.x_m) * step / d,
                sp.z_m + (self.target.z_m - sp.z_m) * step / d,
            )
        };
        self.setpoint = Some(next);
        let k = 0.05;
        let torques = JointTorques {
            torque_nm: [
                (next.x_m - s.position_rad[0]) / (0.5 * 0.005) * k,
                (next.z_m - s.position_rad[1]) / (0.5 * 0.005) * k,
                0.0,
            ],
        };
        let here = SurfacePoint::new(s.position_rad[0], s.position_rad[1]);
        let done = next == self.target;
        if done && self.finished_s.is_none() {
            self.finished_s = Some(now);
        }
        let to_go = here.distance_to(&self.target);
        let settled = done && to_go < 5e-4 && !self.restless;
        let timed_out = self.finished_s.is_some_and(|t| now - t >= SETTLE_TIMEOUT_S);
        let reason = if self.restless {
            control::motion::ShortfallReason::NotAtRest
        } else {
            control::motion::ShortfallReason::Stalled
        };
        Ok(ServoStep {
            torques,
            setpoint: next,
            setpoint_rad: [next.x_m, next.z_m, 0.2],
            settled,
            shortfall: (timed_out && !settled).then_some(control::motion::Shortfall {
                distance_m: to_go,
                reason,
            }),
        })
    }
}

/// Seeds after 50 settled frames at a mark; while tracking, locates every 20 settled frames
/// and steps 5 mm along x until the length is reached.
pub struct FakeTracker {
    phase: TrackerPhase,
    seeds: usize,
    count: u32,
    limit: TrackLimit,
    followed: f64,
    last: Option<SurfacePoint>,
    target: Option<SurfacePoint>,
    stop: bool,
    pub stepped: Arc<AtomicBool>,
}

impl FakeTracker {
    pub fn new() -> Self {
        Self {
            phase: TrackerPhase::Seeding { seeds: 0 },
            seeds: 0,
            count: 0,
            limit: TrackLimit::default(),
            followed: 0.0,
            last: None,
            target: None,
            stop: false,
            stepped: Arc::new(AtomicBool::new(false)),
        }
    }
}

fn located(t_s: f64, at: SurfacePoint, seed: bool) -> TrackerEvent {
    TrackerEvent::Located(LocatedPoint {
        t_s,
        point: at,
        sensor: at,
        element: 4.5,
        amplitude_n: 0.05,
        seed,
        sd_m: None,
    })
}

impl Tracker for FakeTracker {
    fn name(&self) -> &'static str {
        "fake"
    }
    fn phase(&self) -> TrackerPhase {
        self.phase
    }
    fn mark(&mut self) -> Result<(), TrackerError> {
        match self.phase {
            TrackerPhase::Seeding { .. } => {
                self.phase = TrackerPhase::Marking;
                self.count = 0;
                Ok(())
            }
            p => Err(TrackerError::WrongPhase {
                verb: "mark",
                phase: p.as_str(),
            }),
        }
    }
    fn start(&mut self, limit: TrackLimit) -> Result<(), TrackerError> {
        if self.seeds < 2 {
            return Err(TrackerError::NotSeeded { have: self.seeds });
        }
        self.phase = TrackerPhase::Tracking;
        self.limit = limit;
        self.count = 0;
        Ok(())
    }
    fn stop(&mut self) {
        self.stop = true;
    }
    fn target_unreachable(&mut self) {
        self.phase = TrackerPhase::Finished(EndReason::WorkspaceEdge);
    }
    fn step(&mut self, input: &TrackerInput<'_>) -> TrackerOutput {
        self.stepped.store(true, Ordering::Relaxed);
        let t = input.frame.t_s;
        if self.stop {
            self.phase = TrackerPhase::Finished(EndReason::Stopped);
            self.stop = false;
            return TrackerOutput {
                motion: MotionCommand::Hold,
                event: Some(TrackerEvent::Finished {
                    t_s: t,
                    reason: EndReason::Stopped,
                }),
            };
        }
        match self.phase {
            TrackerPhase::Marking => {
                if input.settled {
                    self.count += 1;
                }
                if self.count >= 50 {
                    self.seeds += 1;
                    self.phase = TrackerPhase::Seeding { seeds: self.seeds };
                    self.last = Some(input.sensor);
                    return TrackerOutput {
                        motion: MotionCommand::Hold,
                        event: Some(located(t, input.sensor, true)),
                    };
                }
                TrackerOutput::HOLD
            }
            TrackerPhase::Tracking => {
                let Some(target) = self.target else {
                    let from = input.sensor;
                    let target = SurfacePoint::new(from.x_m + 0.005, from.z_m);
                    self.target = Some(target);
                    return TrackerOutput {
                        motion: MotionCommand::MoveTo {
                            target,
                            speed_m_s: 0.01,
                        },
                        event: None,
                    };
                };
                if !input.settled {
                    self.count = 0;
                    return TrackerOutput {
                        motion: MotionCommand::MoveTo {
                            target,
                            speed_m_s: 0.01,
                        },
                        event: None,
                    };
                }
                self.count += 1;
                if self.count < 20 {
                    return TrackerOutput {
                        motion: MotionCommand::MoveTo {
                            target,
                            speed_m_s: 0.01,
                        },
                        event: None,
                    };
                }
                self.count = 0;
                if let Some(l) = self.last {
                    self.followed += l.distance_to(&input.sensor);
                }
                self.last = Some(input.sensor);
                self.target = None;
                if let Some(len) = self.limit.length_m
                    && self.followed >= len - 1e-9
                {
                    self.phase = TrackerPhase::Finished(EndReason::LengthReached);
                    return TrackerOutput {
                        motion: MotionCommand::Hold,
                        event: Some(TrackerEvent::Finished {
                            t_s: t,
                            reason: EndReason::LengthReached,
                        }),
                    };
                }
                TrackerOutput {
                    motion: MotionCommand::Hold,
                    event: Some(located(t, input.sensor, false)),
                }
            }
            _ => TrackerOutput::HOLD,
        }
    }
}
