//! [`PhantomCan`]: control's `Manipulator` port over the Phantom's CAN amplifiers.
//!
//! Synchronous and non-blocking: each `read_joints` drains what the adapter has received,
//! sends the host heartbeat when due and runs the feedback watchdog; `write_torques` sends
//! one torque frame per joint. Faults latch: bus-off, error-passive, stale feedback, an
//! amplifier's emergency or e-stop, a lost adapter. On a fault every frame still queued for
//! transmission is discarded and a broadcast disable is the only frame sent, so no old
//! command reaches the arm when an e-stop is released. Two ways out, both refused while the
//! cause is still present: `recover` (the daemon's `reset`: reopens a lost adapter, asks the
//! amplifiers to clear their faults, leaves the arm disabled) and `enable`.

use std::sync::Arc;

use config::schema::CanJoints;
use control::ports::Manipulator;
use control::types::{JOINTS, JointState, JointTorques};

use super::adapter::{AdapterError, CanAdapter};
use super::frame::{BusCondition, BusEvent, DataFrame};
use super::protocol::{ControlCommand, Message, NodeState, status};
use super::scaling::JointScaling;
use crate::burst_log::BurstLog;
use crate::clock::Clock;

/// Received events handled per call at most, so a flooded bus cannot stall the loop.
const MAX_EVENTS_PER_CALL: usize = 256;

/// Consecutive cycles with a full transmit queue before it is a fault.
const TX_FULL_LIMIT: u32 = 3;

/// Feedback older than this is not used to compute a velocity difference, s.
const MAX_VELOCITY_GAP_S: f64 = 0.03;

/// `recover` is called every control cycle while a reset waits for its cause to clear:
/// reopening a lost adapter and asking the amplifiers to clear their faults are repeated no
/// more often than this, s.
const RETRY_INTERVAL_S: f64 = 0.1;

/// A run of the same adapter problem is logged once per burst; a burst ends after this
/// quiet time, s.
const BURST_QUIET_S: f64 = 2.0;

/// Why the arm was stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Fault {
    #[error("CAN bus-off on {adapter}: check wiring, termination and bitrate")]
    BusOff { adapter: String },
    #[error(
        "CAN controller error-passive on {adapter}: the bus is failing (wiring, termination, a node at the wrong bitrate)"
    )]
    ErrorPassive { adapter: String },
    #[error(
        "joint {joint} feedback is {age_s:.4} s old (limit {limit_s} s): amplifier silent or bus down"
    )]
    FeedbackTimeout {
        joint: usize,
        age_s: f64,
        limit_s: f64,
    },
    #[error(
        "joint {joint} amplifier reports emergency code {code:#06x} (error register {error_register:#04x})"
    )]
    Emergency {
        joint: usize,
        code: u16,
        error_register: u8,
    },
    #[error("joint {joint} amplifier reports a fault (status {status:#04x})")]
    Amplifier { joint: usize, status: u8 },
    #[error("e-stop open (reported by joint {joint}'s amplifier)")]
    EStop { joint: usize },
    #[error("amplifiers did not all report enabled within {limit_s} s")]
    EnableTimeout { limit_s: f64 },
    #[error(
        "transmit queue full for {TX_FULL_LIMIT} cycles on {adapter}: bus saturated or disconnected"
    )]
    TxOverrun { adapter: String },
    #[error("non-finite torque command for joint {joint}")]
    NonFiniteTorque { joint: usize },
    #[error("CAN adapter {adapter} failed: {message}")]
    Adapter { adapter: String, message: String },
}

/// Errors of the manipulator port.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CanError {
    #[error("arm faulted: {0}")]
    Faulted(Fault),
    #[error(
        "no feedback yet from joint {joint} (node {node}): is the amplifier powered and on the bus?"
    )]
    NoFeedback { joint: usize, node: u8 },
    #[error("cannot enable: {0}")]
    CannotEnable(String),
    /// `recover` refused: the fault's cause is still there; the text names it.
    #[error("{0}")]
    NotRecovered(String),
}

/// Where the drive is.
#[derive(Debug, Clone, PartialEq)]
pub enum DriveState {
    Disabled,
    /// Enable sent; waiting for every amplifier to report enabled.
    Enabling {
        since_s: f64,
    },
    Enabled,
    Fault(Fault),
}

/// Counters since start.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CanStats {
    pub frames_received: u64,
    pub feedback: u64,
    pub feedback_gaps: u64,
    pub feedback_duplicates: u64,
    /// Feedback implying an impossible joint speed (an encoder glitch).
    pub implausible_feedback: u64,
    /// Frames on protocol ids that do not decode (wrong length, undefined values).
    pub malformed: u64,
    /// Frames outside the protocol, or from nodes that are not ours.
    pub foreign: u64,
    pub bus_warnings: u64,
    pub bus_errors_other: u64,
    pub frames_sent: u64,
    pub tx_full: u64,
    pub torque_clamped: u64,
    pub faults: u64,
}

#[derive(Debug, Clone, Copy, Default)]
struct JointTrack {
    counts: Option<i32>,
    seq: Option<u8>,
    amp_time_us: u16,
    rx_s: f64,
    position_rad: f64,
    velocity_rad_s: f64,
    status: u8,
}

/// The Phantom's joints on a CAN adapter.
#[derive(Debug)]
pub struct PhantomCan<A: CanAdapter> {
    adapter: A,
    settings: CanJoints,
    scaling: [JointScaling; JOINTS],
    clock: Arc<dyn Clock>,
    state: DriveState,
    joints: [JointTrack; JOINTS],
    bus_ok: bool,
    torque_seq: u8,
    last_heartbeat_s: f64,
    tx_full_cycles: u32,
    stats: CanStats,
    /// The adapter failed (unplugged, interface gone) and has not been reopened: why.
    adapter_lost: Option<String>,
    last_reopen_s: f64,
    last_clear_fault_s: f64,
    malformed_log: BurstLog,
    warning_log: BurstLog,
    sequence_log: BurstLog,
    stop_log: BurstLog,
}

impl<A: CanAdapter> PhantomCan<A> {
    /// A driver on `adapter`; it starts disabled. `clock` is the control loop's clock.
    pub fn new(adapter: A, settings: &CanJoints, clock: Arc<dyn Clock>) -> Self {
        Self {
            adapter,
            scaling: JointScaling::for_joints(settings),
            settings: settings.clone(),
            clock,
            state: DriveState::Disabled,
            joints: [JointTrack::default(); JOINTS],
            bus_ok: true,
            torque_seq: 0,
            last_heartbeat_s: f64::NEG_INFINITY,
            tx_full_cycles: 0,
            stats: CanStats::default(),
            adapter_lost: None,
            last_reopen_s: f64::NEG_INFINITY,
            last_clear_fault_s: f64::NEG_INFINITY,
            malformed_log: BurstLog::new("CAN: malformed frames", BURST_QUIET_S),
            warning_log: BurstLog::new("CAN: bus errors", BURST_QUIET_S),
            sequence_log: BurstLog::new("CAN: lost feedback frames", BURST_QUIET_S),
            stop_log: BurstLog::new("CAN: stopping the amplifiers failed", BURST_QUIET_S),
        }
    }

    pub fn state(&self) -> &DriveState {
        &self.state
    }

    pub fn stats(&self) -> CanStats {
        self.stats
    }

    pub fn adapter(&self) -> &A {
        &self.adapter
    }

    /// Process everything received, send the heartbeat when due, check the watchdog.
    /// Called by `read_joints`; public so a caller can keep the link serviced without
    /// reading.
    pub fn service(&mut self) {
        let now = self.clock.now_s();
        // A lost adapter is not read again until `recover` reopens it.
        let events = if self.adapter_lost.is_some() {
            0
        } else {
            MAX_EVENTS_PER_CALL
        };
        for _ in 0..events {
            match self.adapter.recv() {
                Ok(Some(ev)) => self.handle(ev, now),
                Ok(None) => break,
                Err(e) => {
                    self.lose_adapter(e.to_string());
                    break;
                }
            }
        }
        self.stop_log.end_if_quiet(now);
        self.malformed_log.end_if_quiet(now);
        self.warning_log.end_if_quiet(now);
        self.sequence_log.end_if_quiet(now);

        if now - self.last_heartbeat_s >= self.settings.heartbeat_period_s {
            self.last_heartbeat_s = now;
            let state = match self.state {
                DriveState::Disabled => NodeState::Disabled,
                DriveState::Enabling { .. } | DriveState::Enabled => NodeState::Enabled,
                DriveState::Fault(_) => NodeState::Fault,
            };
            let hb = Message::Heartbeat {
                node: self.settings.host_node_id,
                state,
                error_register: 0,
            };
            // A heartbeat that does not fit is not itself a fault; the amplifiers' own
            // timeout covers a host that cannot reach them.
            let _ = self.send(&hb.encode());
        }

        let moving = matches!(
            self.state,
            DriveState::Enabling { .. } | DriveState::Enabled
        );
        if moving {
            for j in 0..JOINTS {
                let age_s = now - self.joints[j].rx_s;
                if self.joints[j].counts.is_none() || age_s > self.settings.feedback_timeout_s {
                    self.fault(Fault::FeedbackTimeout {
                        joint: j,
                        age_s,
                        limit_s: self.settings.feedback_timeout_s,
                    });
                    return;
                }
            }
        }
        if let DriveState::Enabling { since_s } = self.state {
            if self.joints.iter().all(|j| j.status & status::ENABLED != 0) {
                tracing::info!("CAN: all amplifiers enabled");
                self.state = DriveState::Enabled;
            } else if now - since_s > self.settings.enable_timeout_s {
                self.fault(Fault::EnableTimeout {
                    limit_s: self.settings.enable_timeout_s,
                });
            }
        }
    }

    fn joint_of(&self, node: u8) -> Option<usize> {
        self.settings.node_ids.iter().position(|&n| n == node)
    }

    fn handle(&mut self, ev: BusEvent, now: f64) {
        match ev {
            BusEvent::Foreign => self.stats.foreign += 1,
            BusEvent::Condition(c) => self.handle_condition(c, now),
            BusEvent::Frame(f) => {
                self.stats.frames_received += 1;
                match Message::decode(&f) {
                    Ok(Some(m)) => self.handle_message(m, now),
                    Ok(None) => self.stats.foreign += 1,
                    Err(e) => {
                        self.stats.malformed += 1;
                        self.malformed_log.event(now, || e.to_string());
                    }
                }
            }
        }
    }

    fn handle_condition(&mut self, c: BusCondition, now: f64) {
        let adapter = self.adapter.describe();
        if c.bus_off {
            self.bus_ok = false;
            self.fault(Fault::BusOff { adapter });
        } else if c.error_passive {
            self.bus_ok = false;
            self.fault(Fault::ErrorPassive { adapter });
        }
        if c.error_warning {
            self.stats.bus_warnings += 1;
            self.warning_log.event(now, || {
                "controller error counters past the warning level".into()
            });
        }
        if c.other {
            self.stats.bus_errors_other += 1;
            self.warning_log.event(now, || {
                "bus error (protocol violation, no ACK, overflow or lost arbitration)".into()
            });
        }
        if c.restarted || c.back_to_active {
            if !self.bus_ok {
                tracing::info!("CAN: controller back on the bus (error-active)");
            }
            self.bus_ok = true;
        }
    }

    fn handle_message(&mut self, m: Message, now: f64) {
        match m {
            Message::Feedback {
                node,
                counts,
                amp_time_us,
                status,
                seq,
            } => {
                let Some(j) = self.joint_of(node) else {
                    self.stats.foreign += 1;
                    return;
                };
                self.feedback(j, counts, amp_time_us, status, seq, now);
            }
            Message::Emergency {
                node,
                code,
                error_register,
                ..
            } => {
                let Some(j) = self.joint_of(node) else {
                    self.stats.foreign += 1;
                    return;
                };
                // Code 0 is "error reset": the amplifier saying its fault cleared.
                if code != 0 {
                    self.fault(Fault::Emergency {
                        joint: j,
                        code,
                        error_register,
                    });
                }
            }
            Message::Heartbeat { node, state, .. } => {
                let Some(j) = self.joint_of(node) else {
                    // Our own heartbeat looped back, or another node's.
                    self.stats.foreign += 1;
                    return;
                };
                let moving = matches!(
                    self.state,
                    DriveState::Enabling { .. } | DriveState::Enabled
                );
                if state == NodeState::Fault || (moving && state == NodeState::Boot) {
                    self.fault(Fault::Amplifier {
                        joint: j,
                        status: self.joints[j].status,
                    });
                }
            }
            // Host-side messages seen on the bus (another host?): not ours to act on.
            Message::Control { .. } | Message::Torque { .. } => self.stats.foreign += 1,
        }
    }

    fn feedback(&mut self, j: usize, counts: i32, amp_time_us: u16, st: u8, seq: u8, now: f64) {
        let track = self.joints[j];
        if let Some(prev) = track.seq {
            let ahead = seq.wrapping_sub(prev);
            if ahead == 0 {
                self.stats.feedback_duplicates += 1;
                return;
            }
            if ahead > 1 && ahead < 128 {
                self.stats.feedback_gaps += 1;
                self.sequence_log.event(now, || {
                    format!("joint {j}: {} feedback frames lost", ahead - 1)
                });
            }
        }
        let s = self.scaling[j];
        let position = s.angle_rad(counts);
        let mut velocity = track.velocity_rad_s;
        if let Some(prev_counts) = track.counts {
            let host_dt = now - track.rx_s;
            let amp_dt = f64::from(amp_time_us.wrapping_sub(track.amp_time_us)) * 1e-6;
            let dt = if host_dt < MAX_VELOCITY_GAP_S && amp_dt > 0.0 {
                amp_dt
            } else {
                host_dt
            };
            let delta = position - s.angle_rad(prev_counts);
            if dt > 0.0 && dt < MAX_VELOCITY_GAP_S {
                let raw = delta / dt;
                if raw.abs() > self.settings.max_joint_speed_rad_s {
                    self.stats.implausible_feedback += 1;
                    self.malformed_log.event(now, || {
                        format!(
                            "joint {j}: encoder jumped {delta:.4} rad in {dt:.4} s; frame dropped"
                        )
                    });
                    return;
                }
                let alpha = dt / (self.settings.velocity_filter_s + dt);
                velocity += alpha * (raw - velocity);
            } else {
                velocity = 0.0;
            }
        }
        self.stats.feedback += 1;
        self.joints[j] = JointTrack {
            counts: Some(counts),
            seq: Some(seq),
            amp_time_us,
            rx_s: now,
            position_rad: position,
            velocity_rad_s: velocity,
            status: st,
        };
        let moving = matches!(
            self.state,
            DriveState::Enabling { .. } | DriveState::Enabled
        );
        if st & status::ESTOP != 0 && moving {
            self.fault(Fault::EStop { joint: j });
        } else if st & (status::FAULT | status::OVER_TEMPERATURE) != 0 && moving {
            self.fault(Fault::Amplifier {
                joint: j,
                status: st,
            });
        } else if matches!(self.state, DriveState::Enabled) && st & status::ENABLED == 0 {
            // An amplifier dropped out of enabled on its own (its command watchdog, a
            // brown-out): the arm is no longer under control.
            self.fault(Fault::Amplifier {
                joint: j,
                status: st,
            });
        }
    }

    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError> {
        if let Some(why) = &self.adapter_lost {
            return Err(AdapterError::Io(why.clone()));
        }
        let r = self.adapter.send(frame);
        match &r {
            Ok(()) => self.stats.frames_sent += 1,
            Err(AdapterError::TxFull) => self.stats.tx_full += 1,
            Err(AdapterError::Io(message)) => self.lose_adapter(message.clone()),
        }
        r
    }

    /// The adapter failed: latch the fault and stop using it until `recover` reopens it.
    fn lose_adapter(&mut self, message: String) {
        let adapter = self.adapter.describe();
        self.fault(Fault::Adapter {
            adapter,
            message: message.clone(),
        });
        self.adapter_lost = Some(message);
    }

    /// Latch a fault: drop queued frames, broadcast disable. The first fault is kept.
    fn fault(&mut self, f: Fault) {
        if let DriveState::Fault(_) = self.state {
            return;
        }
        if matches!(f, Fault::Adapter { .. }) {
            tracing::error!(
                "CAN: {f}; the amplifiers disable themselves on their host-heartbeat timeout"
            );
        } else {
            tracing::error!("CAN: {f}; all axes disabled, queued frames dropped");
        }
        self.stats.faults += 1;
        self.state = DriveState::Fault(f);
        self.stop_all();
    }

    /// Discard queued frames and broadcast a disable. Nothing to reach on a lost adapter.
    fn stop_all(&mut self) {
        if self.adapter_lost.is_some() {
            return;
        }
        let now = self.clock.now_s();
        if let Err(e) = self.adapter.discard_pending_tx() {
            self.stop_log
                .event(now, || format!("could not discard queued frames: {e}"));
        }
        let disable = Message::Control {
            command: ControlCommand::Disable,
            node: 0,
        };
        if let Err(e) = self.send(&disable.encode()) {
            self.stop_log.event(now, || {
                format!(
                    "disable not queued ({e}); amplifiers fall back on their host-heartbeat timeout"
                )
            });
        }
    }

    /// Reopen a lost adapter, at most every [`RETRY_INTERVAL_S`]. True if it is usable.
    fn reopen_if_lost(&mut self, now: f64) -> bool {
        if self.adapter_lost.is_none() {
            return true;
        }
        if now - self.last_reopen_s < RETRY_INTERVAL_S {
            return false;
        }
        self.last_reopen_s = now;
        match self.adapter.reopen() {
            Ok(()) => {
                tracing::info!("CAN: {} reopened", self.adapter.describe());
                self.adapter_lost = None;
                // Nothing from before the loss describes the arm now.
                self.joints = [JointTrack::default(); JOINTS];
                self.bus_ok = true;
                self.tx_full_cycles = 0;
                self.last_heartbeat_s = f64::NEG_INFINITY;
                true
            }
            Err(e) => {
                self.adapter_lost = Some(e.to_string());
                false
            }
        }
    }

    /// Why the latched fault cannot be cleared now, if it cannot: the same checks as
    /// enabling, plus an amplifier that still reports a fault.
    fn recover_blocker(&self, now: f64) -> Option<String> {
        if let Some(why) = self.enable_blocker(now) {
            return Some(why);
        }
        for (j, t) in self.joints.iter().enumerate() {
            if t.status & (status::FAULT | status::OVER_TEMPERATURE) != 0 {
                let node = self.settings.node_ids[j];
                let heat = if t.status & status::OVER_TEMPERATURE != 0 {
                    ", over-temperature"
                } else {
                    ""
                };
                return Some(format!(
                    "the amplifier of joint {j} (node {node}) still reports a fault (status {:#04x}{heat}) after being asked to clear it",
                    t.status
                ));
            }
        }
        None
    }

    /// Why enabling now would be unsafe, if it would be.
    fn enable_blocker(&self, now: f64) -> Option<String> {
        if let Some(why) = &self.adapter_lost {
            return Some(format!(
                "CAN adapter {} not available: {why}",
                self.adapter.describe()
            ));
        }
        if !self.bus_ok {
            return Some(format!(
                "{} is not error-active (bus-off or error-passive); fix the bus and wait for the controller to recover",
                self.adapter.describe()
            ));
        }
        for (j, t) in self.joints.iter().enumerate() {
            let node = self.settings.node_ids[j];
            if t.counts.is_none() || now - t.rx_s > self.settings.feedback_timeout_s {
                return Some(format!(
                    "no fresh feedback from joint {j} (node {node}); is the amplifier powered?"
                ));
            }
            if t.status & status::ESTOP != 0 {
                return Some(format!(
                    "e-stop open on joint {j} (node {node}); release it first"
                ));
            }
        }
        None
    }
}

impl<A: CanAdapter> Manipulator for PhantomCan<A> {
    type Error = CanError;

    fn enable(&mut self) -> Result<(), CanError> {
        self.service();
        let now = self.clock.now_s();
        if let Some(why) = self.enable_blocker(now) {
            return Err(CanError::CannotEnable(why));
        }
        if let DriveState::Fault(f) = &self.state {
            tracing::info!("CAN: clearing latched fault ({f}) on request");
        }
        if matches!(self.state, DriveState::Enabled) {
            return Ok(());
        }
        // Nothing old may follow the enable onto the bus.
        let _ = self.adapter.discard_pending_tx();
        self.tx_full_cycles = 0;
        for command in [ControlCommand::ClearFault, ControlCommand::Enable] {
            let m = Message::Control { command, node: 0 };
            if let Err(e) = self.send(&m.encode()) {
                return Err(CanError::CannotEnable(format!("enable not sent: {e}")));
            }
        }
        self.state = DriveState::Enabling { since_s: now };
        Ok(())
    }

    /// Clear a latched fault once its cause is gone; the arm stays disabled. Never blocks:
    /// a caller that waits for the bus to come back calls it again (each call reopens a
    /// lost adapter and re-sends clear-faults at most every 0.1 s).
    fn recover(&mut self) -> Result<(), CanError> {
        let now = self.clock.now_s();
        if !self.reopen_if_lost(now) {
            let why = self.adapter_lost.clone().unwrap_or_default();
            return Err(CanError::NotRecovered(format!(
                "CAN adapter {} not available: {why}",
                self.adapter.describe()
            )));
        }
        self.service();
        let DriveState::Fault(latched) = &self.state else {
            return Ok(());
        };
        let latched = latched.clone();
        let now = self.clock.now_s();
        let amp_fault = self
            .joints
            .iter()
            .any(|t| t.status & (status::FAULT | status::OVER_TEMPERATURE) != 0);
        if amp_fault && now - self.last_clear_fault_s >= RETRY_INTERVAL_S {
            // Clear-faults leaves the amplifiers disabled (docs/protocols/phantom-can.md).
            self.last_clear_fault_s = now;
            let m = Message::Control {
                command: ControlCommand::ClearFault,
                node: 0,
            };
            let _ = self.send(&m.encode());
        }
        if let Some(why) = self.recover_blocker(now) {
            return Err(CanError::NotRecovered(why));
        }
        tracing::info!("CAN: latched fault ({latched}) cleared on reset; the arm stays disabled");
        self.state = DriveState::Disabled;
        self.tx_full_cycles = 0;
        Ok(())
    }

    fn disable(&mut self) -> Result<(), CanError> {
        self.stop_all();
        if !matches!(self.state, DriveState::Fault(_)) {
            self.state = DriveState::Disabled;
        }
        Ok(())
    }

    fn read_joints(&mut self) -> Result<JointState, CanError> {
        self.service();
        if let DriveState::Fault(f) = &self.state {
            return Err(CanError::Faulted(f.clone()));
        }
        let mut state = JointState {
            t_s: f64::INFINITY,
            position_rad: [0.0; JOINTS],
            velocity_rad_s: [0.0; JOINTS],
        };
        for (j, t) in self.joints.iter().enumerate() {
            if t.counts.is_none() {
                return Err(CanError::NoFeedback {
                    joint: j,
                    node: self.settings.node_ids[j],
                });
            }
            // The state is as old as its oldest joint.
            state.t_s = state.t_s.min(t.rx_s);
            state.position_rad[j] = t.position_rad;
            state.velocity_rad_s[j] = t.velocity_rad_s;
        }
        Ok(state)
    }

    fn write_torques(&mut self, torques: &JointTorques) -> Result<(), CanError> {
        let mut commands = [0i16; JOINTS];
        for (j, &t) in torques.torque_nm.iter().enumerate() {
            match self.scaling[j].motor_command(t) {
                Some(c) => {
                    commands[j] = c.counts;
                    self.stats.torque_clamped += u64::from(c.clamped);
                }
                None => {
                    self.fault(Fault::NonFiniteTorque { joint: j });
                    break;
                }
            }
        }
        match &self.state {
            DriveState::Fault(f) => return Err(CanError::Faulted(f.clone())),
            DriveState::Disabled | DriveState::Enabling { .. } => return Ok(()),
            DriveState::Enabled => {}
        }
        self.torque_seq = self.torque_seq.wrapping_add(1);
        let mut full = false;
        for (j, &torque) in commands.iter().enumerate() {
            let m = Message::Torque {
                node: self.settings.node_ids[j],
                torque,
                seq: self.torque_seq,
            };
            match self.send(&m.encode()) {
                Ok(()) => {}
                Err(AdapterError::TxFull) => full = true,
                Err(AdapterError::Io(message)) => {
                    let adapter = self.adapter.describe();
                    self.fault(Fault::Adapter { adapter, message });
                    break;
                }
            }
        }
        self.tx_full_cycles = if full { self.tx_full_cycles + 1 } else { 0 };
        if self.tx_full_cycles >= TX_FULL_LIMIT {
            let adapter = self.adapter.describe();
            self.fault(Fault::TxOverrun { adapter });
        }
        match &self.state {
            DriveState::Fault(f) => Err(CanError::Faulted(f.clone())),
            _ => Ok(()),
        }
    }
}
