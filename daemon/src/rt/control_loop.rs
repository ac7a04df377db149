//! One cycle of the 1 kHz loop: read the joints, drain the tactile array, apply commands,
//! run the safety layer and the servo, write torques, publish. No allocation and no
//! blocking on the normal path: ports are non-blocking, channels are bounded and written
//! with `try_send`, the status goes to a latest-value slot. Errors allocate only when they
//! fault the loop, which then stops commanding torque; a port error that repeats every cycle
//! (a latched or unplugged arm) is logged once per burst, with its count when it ends.

mod joint_sweep_mode;

use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender, TrySendError};

use control::types::{JointState, JointTorques, Joints};
use drivers::burst_log::BurstLog;

use crate::backend::{ArmPort, TactilePort};
use crate::rt::fault::{Fault, FaultKind};
use crate::rt::flight_recorder::{CycleRecord, FlightRecorder};
use crate::rt::link::{
    ControlCommand, ControlEvent, ControlStatus, LoopMode, LoopSample, Refusal, StampedFrame,
};
use crate::rt::safety::{self, SafetyLimits, TorqueGuard};
use crate::rt::servo::{SensorPose, Servo};
use crate::slot::Slot;

/// Frames and commands handled per cycle at most (the rest wait for the next cycle).
const MAX_FRAMES_PER_CYCLE: usize = 32;
const MAX_COMMANDS_PER_CYCLE: usize = 16;

/// How long a `reset` waits for the fault's cause to clear before it is refused, daemon
/// clock s: a reopened CAN adapter needs a few feedback frames, an amplifier a moment to
/// clear its fault. The loop keeps cycling meanwhile; nothing blocks.
const RESET_WAIT_S: f64 = 0.25;

/// A run of the same port error ends after this long without one, s.
const BURST_QUIET_S: f64 = 2.0;

/// The port errors that can repeat every cycle, each logged once per burst.
#[derive(Debug)]
struct PortLogs {
    read: BurstLog,
    write: BurstLog,
    tactile: BurstLog,
    power: BurstLog,
}

impl PortLogs {
    fn new() -> Self {
        Self {
            read: BurstLog::new("control loop: reading joints failed", BURST_QUIET_S),
            write: BurstLog::new("control loop: writing torques failed", BURST_QUIET_S),
            tactile: BurstLog::new("control loop: tactile port error", BURST_QUIET_S),
            power: BurstLog::new(
                "control loop: switching the arm's power failed",
                BURST_QUIET_S,
            ),
        }
    }

    /// Close bursts that have gone quiet (logging their counts). Four flag tests per cycle
    /// when nothing is wrong.
    fn tick(&mut self, now: f64) {
        for log in [
            &mut self.read,
            &mut self.write,
            &mut self.tactile,
            &mut self.power,
        ] {
            if log.in_burst() {
                log.end_if_quiet(now);
            }
        }
    }
}

/// A `reset` waiting for the cause of the fault to clear.
#[derive(Debug, Clone, Copy)]
struct PendingReset {
    seq: u64,
    until_s: f64,
}

/// Why fresh joint data could not be had.
enum JointsProblem {
    /// The port's error, in its words.
    Port(String),
    /// The data came but is unusable (stale, non-finite).
    Data(Fault),
}

/// The channels and shared state the loop talks through.
#[derive(Debug, Clone)]
pub struct LoopLinks {
    pub commands: Receiver<ControlCommand>,
    pub events: Sender<ControlEvent>,
    pub samples: Sender<LoopSample>,
    pub status: Arc<Slot<ControlStatus>>,
    pub flight: FlightRecorder,
    /// Send the joint state every this many cycles.
    pub joint_every: u32,
}

pub struct ControlLoop {
    arm: Box<dyn ArmPort>,
    tactile: Box<dyn TactilePort>,
    servo: Box<dyn Servo>,
    limits: SafetyLimits,
    guard: TorqueGuard,
    links: LoopLinks,
    dt_s: f64,
    status: ControlStatus,
    fault: Option<Fault>,
    last_pose: Option<SensorPose>,
    last_seq: u64,
    silence_until_s: f64,
    pending_reset: Option<PendingReset>,
    logs: PortLogs,
    /// Added to every encoder angle the arm reports (a joints calibration's zero), rad.
    zero_offset_rad: Joints,
    /// A change of it this cycle, for the joint state read before it.
    zero_shift: Option<Joints>,
    /// The joint stop sweep under way (`rt/joint_sweep_mode.rs`): joint space, the instrument
    /// out, no rod pose needed.
    sweep: Option<control::calibration::JointSweep>,
}

impl std::fmt::Debug for ControlLoop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ControlLoop")
            .field("status", &self.status)
            .field("fault", &self.fault)
            .finish()
    }
}

impl ControlLoop {
    pub fn new(
        arm: Box<dyn ArmPort>,
        tactile: Box<dyn TactilePort>,
        servo: Box<dyn Servo>,
        limits: SafetyLimits,
        rate_hz: f64,
        links: LoopLinks,
    ) -> Self {
        Self {
            arm,
            tactile,
            servo,
            limits,
            guard: TorqueGuard::new(),
            links,
            dt_s: 1.0 / rate_hz,
            status: ControlStatus::default(),
            fault: None,
            last_pose: None,
            last_seq: 0,
            silence_until_s: f64::NEG_INFINITY,
            pending_reset: None,
            zero_offset_rad: [0.0; 3],
            zero_shift: None,
            sweep: None,
            logs: PortLogs::new(),
        }
    }

    /// Start with `offset_rad` added to every encoder angle (the calibration file's zero).
    pub fn with_zero_offset(mut self, offset_rad: Joints) -> Self {
        self.zero_offset_rad = offset_rad;
        self
    }

    pub fn mode(&self) -> LoopMode {
        self.status.mode
    }

    pub fn now_s(&self) -> f64 {
        self.arm.now_s()
    }

    pub fn truth(&mut self) -> Option<crate::backend::Truth> {
        self.arm.truth()
    }

    /// Run one cycle.
    pub fn cycle(&mut self) {
        let now = self.arm.now_s();
        self.status.t_s = now;
        self.status.cycle += 1;

        let mut joints = self.read_joints(now);
        self.drain_tactile(now);
        for _ in 0..MAX_COMMANDS_PER_CYCLE {
            match self.links.commands.try_recv() {
                Ok(cmd) => self.apply(now, cmd, joints.as_ref()),
                Err(_) => break,
            }
        }
        if let (Some(d), Some(s)) = (self.zero_shift.take(), joints.as_mut()) {
            for (q, d) in s.position_rad.iter_mut().zip(d) {
                *q += d;
            }
        }
        if let Some(pending) = self.pending_reset {
            self.continue_reset(now, pending);
        }

        let torques = if self.status.mode == LoopMode::Enabled {
            let step = |l: &mut Self, s: &JointState| {
                if l.sweep.is_some() {
                    l.sweep_step(now, s)
                } else {
                    l.enabled_step(now, s)
                }
            };
            match joints.as_ref().map(|s| step(self, s)) {
                Some(Ok(t)) => t,
                Some(Err(f)) => {
                    self.latch(f);
                    JointTorques::ZERO
                }
                None => {
                    // read_joints already latched the fault.
                    JointTorques::ZERO
                }
            }
        } else {
            JointTorques::ZERO
        };
        // Always write: the simulator's clock advances with each write, and a disabled rig
        // ignores torques.
        if let Err(e) = self.arm.write_torques(&torques) {
            // A latched arm refuses every write: once per burst, not 1000 lines a second.
            self.logs.write.event(now, || e.to_string());
            self.latch(Fault::new(FaultKind::Backend, now).noting("write_torques failed"));
        }
        self.status.torque_nm = torques.torque_nm;
        self.logs.tick(now);
        self.publish(now);
    }

    fn read_joints(&mut self, now: f64) -> Option<JointState> {
        match self.fresh_joints(now) {
            Ok(s) => Some(s),
            Err(JointsProblem::Port(e)) => {
                if self.status.mode == LoopMode::Enabled {
                    self.logs.read.event(now, || e);
                    self.latch(Fault::new(FaultKind::Backend, now).noting("read_joints failed"));
                }
                None
            }
            Err(JointsProblem::Data(f)) => {
                if self.status.mode == LoopMode::Enabled {
                    self.latch(f);
                }
                None
            }
        }
    }

    /// Read the joints and, if the data is usable, update the believed pose.
    fn fresh_joints(&mut self, now: f64) -> Result<JointState, JointsProblem> {
        let mut state = self
            .arm
            .read_joints()
            .map_err(|e| JointsProblem::Port(e.0))?;
        control::calibration::through_zero(&mut state.position_rad, &self.zero_offset_rad);
        safety::check_joint_data(&self.limits, now, &state).map_err(JointsProblem::Data)?;
        self.status.position_rad = state.position_rad;
        self.status.velocity_rad_s = state.velocity_rad_s;
        self.refresh_pose(now, &state.position_rad);
        Ok(state)
    }

    /// The believed sensor pose at `q`, kept and reported.
    fn refresh_pose(&mut self, now: f64, q: &control::types::Joints) {
        self.last_pose = self.servo.sensor_pose(now, q).ok();
        if let Some(p) = self.last_pose {
            self.status.sensor = p.centre;
            self.status.depth_m = p.depth_m;
        }
    }

    fn drain_tactile(&mut self, now: f64) {
        for _ in 0..MAX_FRAMES_PER_CYCLE {
            let frame = match self.tactile.poll_frame() {
                Ok(Some(f)) => f,
                Ok(None) => break,
                Err(e) => {
                    // A stream error is judged by staleness: the frames stop arriving.
                    self.logs.tactile.event(now, || e.to_string());
                    break;
                }
            };
            if now < self.silence_until_s {
                continue;
            }
            if !frame.is_finite() {
                if self.status.mode == LoopMode::Enabled {
                    self.latch(Fault::new(FaultKind::NonFiniteTactile, now));
                }
                continue;
            }
            let contact_n: f64 = frame.force_n.iter().sum();
            // Read once per frame (not per cycle), and only while the motors hold the arm:
            // unpowered, their torque says nothing about the rod.
            let loaded_sensor = (self.status.mode == LoopMode::Enabled)
                .then(|| {
                    self.servo
                        .sensor_felt(&self.status.position_rad, &self.status.torque_nm)
                })
                .flatten();
            self.status.tactile_t_s = frame.t_s;
            self.status.contact_n = contact_n;
            self.status.tactile_frames += 1;
            let stamped = StampedFrame {
                frame,
                sensor: self.status.sensor,
                height_m: self.last_pose.map_or(f64::NAN, |p| p.height_m),
                loaded_sensor,
                settled: self.status.settled,
                shortfall: self.status.shortfall,
                motion_seq: self.status.motion_seq,
                contact_n,
            };
            if let Err(TrySendError::Full(_)) =
                self.links.samples.try_send(LoopSample::Frame(stamped))
            {
                self.status.dropped += 1;
            }
        }
    }

    fn enabled_step(&mut self, now: f64, state: &JointState) -> Result<JointTorques, Fault> {
        safety::check_joint_limits(&self.limits, now, state)?;
        self.check_tactile(now)?;
        let pose = self
            .last_pose
            .ok_or_else(|| Fault::new(FaultKind::Kinematics, now).noting("sensor pose unknown"))?;
        let step = self.servo.step(now, state, self.dt_s)?;
        safety::check_pose(&self.limits, now, &pose, &step)?;
        let torques = self
            .guard
            .apply(&self.limits, now, self.dt_s, &step.torques)?;
        self.status.setpoint = step.setpoint;
        self.status.setpoint_rad = step.setpoint_rad;
        self.status.settled = step.settled;
        self.status.shortfall = step.shortfall;
        Ok(torques)
    }

    fn apply(&mut self, now: f64, cmd: ControlCommand, joints: Option<&JointState>) {
        let seq = cmd.seq();
        self.last_seq = seq;
        if let ControlCommand::Reset { .. } = cmd {
            return self.begin_reset(now, seq);
        }
        let outcome = match cmd {
            ControlCommand::Estop { .. } => {
                if self.fault.is_none() {
                    self.latch(Fault::new(FaultKind::Estop, now));
                }
                Ok(())
            }
            ControlCommand::Latch { kind, .. } => {
                if self.fault.is_none() {
                    self.latch(Fault::new(kind, now));
                }
                Ok(())
            }
            ControlCommand::SilenceTactile { duration_s, .. } => {
                self.silence_until_s = now + duration_s.max(0.0);
                Ok(())
            }
            // Handled above: its answer may wait for the cause to clear.
            ControlCommand::Reset { .. } => Ok(()),
            _ if self.status.mode == LoopMode::Faulted => Err(Refusal::Faulted),
            ControlCommand::EndSweep { .. } => self.end_sweep(),
            ControlCommand::Disable { .. } => {
                self.sweep = None;
                self.power_off();
                self.status.mode = LoopMode::Disabled;
                Ok(())
            }
            _ if self.sweep.is_some() => Err(Refusal::Cause(
                "a joint stop sweep is under way: stop it first".into(),
            )),
            ControlCommand::SweepStops {
                targets, settings, ..
            } => self.start_sweep(now, joints, targets, settings),
            ControlCommand::Enable { .. } => self.enable(now, joints),
            ControlCommand::Hold { seq } => {
                if self.status.mode != LoopMode::Enabled {
                    Err(Refusal::NotEnabled)
                } else {
                    // After a stop short the setpoint is where the arm could not get: hold
                    // where it is instead, so that nothing is left pushing toward it.
                    let held = match (self.status.shortfall, joints) {
                        (Some(_), Some(state)) => self.servo.hold_here(now, state),
                        _ => {
                            self.servo.hold(now);
                            Ok(())
                        }
                    };
                    match held {
                        Ok(()) => {
                            self.status.motion_seq = seq;
                            self.status.settled = false;
                            self.status.shortfall = None;
                            Ok(())
                        }
                        Err(f) => {
                            self.latch(f);
                            Err(Refusal::Faulted)
                        }
                    }
                }
            }
            ControlCommand::MoveTo {
                seq,
                target,
                speed_m_s,
            } => self.start_motion(seq, target.x_m, target.z_m, |s| {
                s.move_to(now, target, speed_m_s)
            }),
            ControlCommand::MoveToPoint {
                seq,
                target,
                speed_m_s,
            } => self.start_motion(seq, target.x, target.z, |s| {
                s.move_to_point(now, target, speed_m_s)
            }),
            ControlCommand::SetPlacement { seq, placement } => {
                self.replace_model(now, seq, joints, |s, state| {
                    s.set_placement(now, placement, state)
                })
            }
            ControlCommand::SetPivot { seq, pivot } => {
                self.replace_model(now, seq, joints, |s, state| s.set_pivot(now, pivot, state))
            }
            ControlCommand::SetJointZero { offset_rad, .. } => {
                self.set_joint_zero(now, joints, offset_rad)
            }
        };
        let event = match outcome {
            Ok(()) => ControlEvent::Done { seq, t_s: now },
            Err(why) => ControlEvent::Refused { seq, t_s: now, why },
        };
        self.send_event(event);
    }

    /// A joints calibration's zero: every angle from now on reads `offset_rad` more than the
    /// encoders say; powered, the setpoint becomes the pose as newly read, so nothing moves.
    fn set_joint_zero(
        &mut self,
        now: f64,
        joints: Option<&JointState>,
        offset_rad: Joints,
    ) -> Result<(), Refusal> {
        if !offset_rad.iter().all(|v| v.is_finite()) {
            return Err(Refusal::Unreachable(FaultKind::NonFiniteCommand));
        }
        let mut delta = [0.0; 3];
        for (j, d) in delta.iter_mut().enumerate() {
            *d = offset_rad[j] - self.zero_offset_rad[j];
        }
        if self.status.mode == LoopMode::Enabled {
            let Some(mut state) = joints.copied() else {
                return Err(Refusal::CauseStillPresent(FaultKind::JointStale));
            };
            for (q, d) in state.position_rad.iter_mut().zip(delta) {
                *q += d;
            }
            self.servo
                .hold_here(now, &state)
                .map_err(|f| Refusal::Unreachable(f.kind))?;
            self.status.setpoint_rad = state.position_rad;
            self.status.settled = false;
        }
        self.zero_offset_rad = offset_rad;
        let mut shift = self.zero_shift.unwrap_or([0.0; 3]);
        for (s, d) in shift.iter_mut().zip(delta) {
            *s += d;
        }
        self.zero_shift = Some(shift);
        let mut q = self.status.position_rad;
        for (q, d) in q.iter_mut().zip(delta) {
            *q += d;
        }
        self.status.position_rad = q;
        self.refresh_pose(now, &q);
        // Whoever hears the answer reads the new angles: the slot before the event.
        self.links.status.write(&self.status);
        Ok(())
    }

    /// A calibration's new kinematics (`replace`: a tissue frame or a pivot), holding where the
    /// arm is while powered (refused without a fresh joint reading to hold at).
    fn replace_model(
        &mut self,
        now: f64,
        seq: u64,
        joints: Option<&JointState>,
        replace: impl FnOnce(&mut dyn Servo, Option<&JointState>) -> Result<(), Refusal>,
    ) -> Result<(), Refusal> {
        let powered = self.status.mode == LoopMode::Enabled;
        let state = if powered { joints } else { None };
        if powered && state.is_none() {
            return Err(Refusal::CauseStillPresent(FaultKind::JointStale));
        }
        replace(self.servo.as_mut(), state)?;
        // The believed pose through the new model before the next step compares it with a
        // setpoint in it.
        let q = self.status.position_rad;
        self.refresh_pose(now, &q);
        if powered {
            self.status.motion_seq = seq;
            self.status.settled = false;
            self.status.shortfall = None;
        }
        Ok(())
    }

    /// A move to a target at (`x_m`, `z_m`) over the surface: refused unpowered or outside the
    /// workspace, else started by `start` and made the motion the loop reports on.
    fn start_motion(
        &mut self,
        seq: u64,
        x_m: f64,
        z_m: f64,
        start: impl FnOnce(&mut dyn Servo) -> Result<(), Refusal>,
    ) -> Result<(), Refusal> {
        if self.status.mode != LoopMode::Enabled {
            return Err(Refusal::NotEnabled);
        }
        if !self.limits.in_workspace(x_m, z_m) {
            return Err(Refusal::Unreachable(FaultKind::Workspace));
        }
        start(self.servo.as_mut())?;
        self.status.motion_seq = seq;
        self.status.settled = false;
        self.status.shortfall = None;
        Ok(())
    }

    fn enable(&mut self, now: f64, joints: Option<&JointState>) -> Result<(), Refusal> {
        let state = &self.joints_to_power(now, joints)?;
        safety::check_joint_limits(&self.limits, now, state)
            .map_err(|f| Refusal::CauseStillPresent(f.kind))?;
        self.tactile_to_power(now)?;
        let pose = self
            .last_pose
            .ok_or(Refusal::CauseStillPresent(FaultKind::Kinematics))?;
        if !(self.limits.min_depth_m..=self.limits.max_depth_m).contains(&pose.depth_m) {
            return Err(Refusal::CauseStillPresent(FaultKind::Depth));
        }
        self.servo
            .hold_here(now, state)
            .map_err(|f| Refusal::CauseStillPresent(f.kind))?;
        if let Err(e) = self.arm.enable() {
            tracing::error!("enabling the arm: {e}");
            return Err(Refusal::Cause(e.0.into()));
        }
        self.guard.reset();
        self.status.mode = LoopMode::Enabled;
        self.status.setpoint = pose.centre;
        self.status.setpoint_rad = state.position_rad;
        self.status.settled = true;
        self.status.shortfall = None;
        Ok(())
    }

    /// The joints to power the unpowered arm from (powered: refused): this cycle's; without
    /// them (the arm may hold a fault of its own, a bus lost while unpowered) its fault
    /// cleared if the cause is gone and fresh joints read, else what the cause is.
    pub(super) fn joints_to_power(
        &mut self,
        now: f64,
        joints: Option<&JointState>,
    ) -> Result<JointState, Refusal> {
        if self.status.mode == LoopMode::Enabled {
            return Err(Refusal::AlreadyEnabled);
        }
        match joints {
            Some(s) => Ok(*s),
            None => self.recover_arm(now).map_err(|p| match p {
                JointsProblem::Port(why) => Refusal::Cause(why.into()),
                JointsProblem::Data(f) => Refusal::CauseStillPresent(f.kind),
            }),
        }
    }

    /// The tactile array's freshness and contact force, as every powered cycle needs them.
    pub(super) fn check_tactile(&self, now: f64) -> Result<(), Fault> {
        safety::check_tactile(
            &self.limits,
            now,
            self.status.tactile_t_s,
            self.status.contact_n,
        )
    }

    /// The same, before powering the arm: a failure is a cause still present.
    pub(super) fn tactile_to_power(&self, now: f64) -> Result<(), Refusal> {
        self.check_tactile(now)
            .map_err(|f| Refusal::CauseStillPresent(f.kind))
    }

    /// Clear the arm's own latched fault if it has one, and read fresh joints.
    fn recover_arm(&mut self, now: f64) -> Result<JointState, JointsProblem> {
        self.arm.recover().map_err(|e| JointsProblem::Port(e.0))?;
        self.fresh_joints(now)
    }

    fn begin_reset(&mut self, now: f64, seq: u64) {
        if self.fault.is_none() {
            return self.send_event(ControlEvent::Refused {
                seq,
                t_s: now,
                why: Refusal::NoFault,
            });
        }
        if let Some(older) = self.pending_reset.take() {
            // The newer request answers for both: the older one is told it was superseded
            // by what the newer finds.
            self.send_event(ControlEvent::Refused {
                seq: older.seq,
                t_s: now,
                why: Refusal::Cause("a newer reset replaced this one".into()),
            });
        }
        // Tried in this same cycle, after the commands (`continue_reset`).
        self.pending_reset = Some(PendingReset {
            seq,
            until_s: now + RESET_WAIT_S,
        });
    }

    /// One attempt of a pending reset: done, refused once its wait is over, or left pending.
    fn continue_reset(&mut self, now: f64, pending: PendingReset) {
        let why = match self.try_reset(now) {
            Ok(()) => {
                self.pending_reset = None;
                return self.send_event(ControlEvent::Done {
                    seq: pending.seq,
                    t_s: now,
                });
            }
            Err(why) => why,
        };
        if now < pending.until_s {
            return;
        }
        self.pending_reset = None;
        let why = match why {
            JointsProblem::Port(text) => Refusal::Cause(text.into()),
            JointsProblem::Data(f) => Refusal::Cause(f.describe().into()),
        };
        self.send_event(ControlEvent::Refused {
            seq: pending.seq,
            t_s: now,
            why,
        });
    }

    /// Clear the latched fault if its cause is gone. The arm stays unpowered, its setpoint
    /// the measured pose.
    fn try_reset(&mut self, now: f64) -> Result<(), JointsProblem> {
        let state = self.recover_arm(now)?;
        self.servo
            .hold_here(now, &state)
            .map_err(JointsProblem::Data)?;
        self.guard.reset();
        self.fault = None;
        self.status.mode = LoopMode::Disabled;
        self.status.settled = true;
        self.status.shortfall = None;
        // What `status` shows as the setpoint is where the arm is now, not where it was
        // steering when the fault struck.
        self.status.setpoint_rad = state.position_rad;
        self.status.setpoint = self.last_pose.map_or(
            control::frames::SurfacePoint::new(f64::NAN, f64::NAN),
            |p| p.centre,
        );
        self.links.flight.thaw();
        Ok(())
    }

    fn power_off(&mut self) {
        if let Err(e) = self.arm.disable() {
            let now = self.arm.now_s();
            self.logs
                .power
                .event(now, || format!("disabling the arm: {e}"));
        }
        self.guard.reset();
    }

    /// Latch a fault: power off, drop queued commands, freeze the flight recorder, report.
    fn latch(&mut self, fault: Fault) {
        if self.fault.is_some() {
            return;
        }
        self.sweep = None;
        self.power_off();
        self.status.mode = LoopMode::Faulted;
        self.fault = Some(fault);
        let mut dropped = 0;
        while let Ok(cmd) = self.links.commands.try_recv() {
            dropped += 1;
            self.send_event(ControlEvent::Refused {
                seq: cmd.seq(),
                t_s: fault.t_s,
                why: Refusal::Faulted,
            });
        }
        let _ = dropped;
        self.record_flight(fault.t_s);
        self.links.flight.freeze();
        self.send_event(ControlEvent::Faulted(fault));
    }

    /// Latch a fault from outside the cycle (the deadline monitor).
    pub fn latch_external(&mut self, fault: Fault) {
        self.latch(fault);
    }

    fn send_event(&mut self, e: ControlEvent) {
        if self.links.events.try_send(e).is_err() {
            self.status.dropped += 1;
        }
    }

    fn record_flight(&self, now: f64) {
        let s = &self.status;
        self.links.flight.record(&CycleRecord {
            t_s: now,
            cycle: s.cycle,
            mode: s.mode as u8,
            position_rad: s.position_rad,
            velocity_rad_s: s.velocity_rad_s,
            setpoint_rad: s.setpoint_rad,
            torque_nm: s.torque_nm,
            sensor_x_m: s.sensor.x_m,
            sensor_z_m: s.sensor.z_m,
            setpoint_x_m: s.setpoint.x_m,
            setpoint_z_m: s.setpoint.z_m,
            contact_n: s.contact_n,
            tactile_age_s: now - s.tactile_t_s,
            command_seq: self.last_seq,
        });
    }

    fn publish(&mut self, now: f64) {
        self.record_flight(now);
        self.links.status.write(&self.status);
        if self
            .status
            .cycle
            .is_multiple_of(u64::from(self.links.joint_every.max(1)))
        {
            let sample = LoopSample::Joints {
                status: self.status,
                truth: self.arm.truth(),
            };
            if let Err(TrySendError::Full(_)) = self.links.samples.try_send(sample) {
                self.status.dropped += 1;
            }
        }
    }

    /// Send an event from the loop's thread (timing reports); false if it had to be dropped.
    pub fn report(&mut self, e: ControlEvent) -> bool {
        let ok = self.links.events.try_send(e).is_ok();
        if !ok {
            self.status.dropped += 1;
        }
        ok
    }

    pub fn set_overruns(&mut self, overruns: u64) {
        self.status.overruns = overruns;
    }

    /// Power off on shutdown and report.
    pub fn shut_down(&mut self) {
        if self.status.mode == LoopMode::Enabled {
            self.power_off();
            self.status.mode = LoopMode::Disabled;
        }
        let now = self.arm.now_s();
        self.publish(now);
        self.send_event(ControlEvent::Stopped { t_s: now });
    }
}
