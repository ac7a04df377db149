//! What travels between the control thread and the rest of the daemon: commands in, events
//! and stamped tactile frames out (bounded crossbeam channels, never blocking the loop), and
//! the loop's status in a latest-value slot.

use std::sync::Arc;

use control::frames::SurfacePoint;
use control::motion::{Shortfall, ShortfallReason};
use control::types::{JOINTS, Joints, TactileFrame};

use crate::rt::fault::{Fault, FaultKind};
use crate::rt::period_stats::PeriodSummary;
use crate::slot::{Packed, Packer, SLOT_WORDS, Unpacker};

/// A request to the loop. Every command carries a sequence number that its answer repeats.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ControlCommand {
    /// Power the arm and hold exactly where it is (setpoint := measured).
    Enable { seq: u64 },
    /// Remove power.
    Disable { seq: u64 },
    /// Come to rest at the current setpoint; after a move that stopped short of its target,
    /// where the arm is (never where it could not get).
    Hold { seq: u64 },
    /// A straight move of the sensor centre, tissue frame.
    MoveTo {
        seq: u64,
        target: SurfacePoint,
        speed_m_s: f64,
    },
    /// A straight move of the sensor centre to a point at any height, tissue frame (the
    /// tissue-frame calibration's lifts and descents).
    MoveToPoint {
        seq: u64,
        target: nalgebra::Point3<f64>,
        speed_m_s: f64,
    },
    /// Put the tissue frame where a calibration found it; powered, the arm holds where it is.
    SetPlacement {
        seq: u64,
        placement: control::frames::TissuePlacement,
    },
    /// Put the pivot where a calibration found it; powered, the arm holds where it is.
    SetPivot {
        seq: u64,
        pivot: control::kinematics::PivotGeometry,
    },
    /// Add `offset_rad` to every encoder angle from now on (a joints calibration's zero);
    /// powered, the arm holds where it is.
    SetJointZero { seq: u64, offset_rad: Joints },
    /// Power the arm in joint space, without the rod through the pivot (the instrument out
    /// of the incision), and sweep `targets` ([`control::calibration::JointSweep`]); when
    /// back where it started, power off and report [`ControlEvent::SweepEnded`].
    SweepStops {
        seq: u64,
        targets: control::calibration::StopTargets,
        settings: control::calibration::JointSettings,
    },
    /// End the sweep under way: straight back to where it started, then power off.
    EndSweep { seq: u64 },
    /// Latch an `estop` fault: power off at once.
    Estop { seq: u64 },
    /// Latch a fault the supervisor found (a failed recording): power off at once.
    Latch { seq: u64, kind: FaultKind },
    /// Clear a latched fault; the arm stays unpowered with its setpoint at the measured pose.
    Reset { seq: u64 },
    /// Test hook: ignore tactile frames for this long (daemon clock), as if the stream died.
    SilenceTactile { seq: u64, duration_s: f64 },
}

impl ControlCommand {
    pub fn seq(&self) -> u64 {
        match *self {
            ControlCommand::Enable { seq }
            | ControlCommand::Disable { seq }
            | ControlCommand::Hold { seq }
            | ControlCommand::MoveTo { seq, .. }
            | ControlCommand::MoveToPoint { seq, .. }
            | ControlCommand::SetPlacement { seq, .. }
            | ControlCommand::SetPivot { seq, .. }
            | ControlCommand::SetJointZero { seq, .. }
            | ControlCommand::SweepStops { seq, .. }
            | ControlCommand::EndSweep { seq }
            | ControlCommand::Estop { seq }
            | ControlCommand::Latch { seq, .. }
            | ControlCommand::Reset { seq }
            | ControlCommand::SilenceTactile { seq, .. } => seq,
        }
    }
}

/// Why the loop refused a command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refusal {
    /// A fault is latched: reset first.
    Faulted,
    /// The arm is not powered.
    NotEnabled,
    /// Already powered.
    AlreadyEnabled,
    /// Nothing latched to reset.
    NoFault,
    /// The fault's cause persists (stale or non-finite data).
    CauseStillPresent(FaultKind),
    /// The fault's cause persists, in the words of whoever sees it (the arm's driver: "e-stop
    /// open on joint 2 (node 3)"). Built only when refusing, never in a normal cycle.
    Cause(Arc<str>),
    /// The target cannot be reached or is outside an allowed range.
    Unreachable(FaultKind),
    /// The backend refused.
    Backend,
}

impl Refusal {
    pub fn describe(&self) -> String {
        match self {
            Refusal::Faulted => "a fault is latched: reset first".into(),
            Refusal::NotEnabled => "the arm is not enabled".into(),
            Refusal::AlreadyEnabled => "the arm is already enabled".into(),
            Refusal::NoFault => "no fault is latched".into(),
            Refusal::CauseStillPresent(k) => {
                format!(
                    "the cause is still present: {}",
                    k.as_str().replace('_', " ")
                )
            }
            Refusal::Cause(why) => format!("the cause is still present: {why}"),
            Refusal::Unreachable(k) => {
                format!("target not allowed: {} limit", k.as_str().replace('_', " "))
            }
            Refusal::Backend => "the backend refused (see the daemon's log)".into(),
        }
    }
}

/// What the loop reports.
#[derive(Debug, Clone, PartialEq)]
pub enum ControlEvent {
    /// A command was carried out.
    Done { seq: u64, t_s: f64 },
    /// A command was refused; nothing changed.
    Refused { seq: u64, t_s: f64, why: Refusal },
    /// A fault was latched: power is off, motion dropped.
    Faulted(Fault),
    /// The loop's rate-limited timing report.
    Timing { t_s: f64, summary: PeriodSummary },
    /// The loop has stopped (shutdown).
    Stopped { t_s: f64 },
    /// The joint sweep found a stop.
    StopFound {
        t_s: f64,
        found: control::calibration::StopFound,
    },
    /// The joint sweep is back where it started and the arm unpowered (`aborted`: it was
    /// ended early), with the stops it found and the pose it ended at, rad.
    SweepEnded {
        t_s: f64,
        findings: control::calibration::Findings,
        aborted: bool,
        at_rad: Joints,
    },
}

/// A tactile frame stamped by the loop with what the robot believed at that instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedFrame {
    pub frame: TactileFrame,
    /// Believed sensor centre (encoders + fixed-pivot model), tissue frame.
    pub sensor: SurfacePoint,
    /// ... and its height, tissue frame, m.
    pub height_m: f64,
    /// Where the arm's load says the sensor centre is (the config's `rod`), while powered.
    pub loaded_sensor: Option<SurfacePoint>,
    /// The motion with this sequence number has arrived (encoders through the kinematics).
    pub settled: bool,
    /// ... or has stopped short of its target, by how much and why.
    pub shortfall: Option<Shortfall>,
    pub motion_seq: u64,
    /// Sum of the element forces, N.
    pub contact_n: f64,
}

/// Data the loop streams out: every tactile frame, and the joint state every few cycles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoopSample {
    Frame(StampedFrame),
    Joints {
        status: ControlStatus,
        truth: Option<crate::backend::Truth>,
    },
}

/// Power state of the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopMode {
    Disabled = 0,
    Enabled = 1,
    Faulted = 2,
}

/// The loop's latest state, published every cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlStatus {
    pub t_s: f64,
    pub cycle: u64,
    pub mode: LoopMode,
    pub position_rad: Joints,
    pub velocity_rad_s: Joints,
    pub torque_nm: Joints,
    pub setpoint_rad: Joints,
    pub sensor: SurfacePoint,
    pub setpoint: SurfacePoint,
    pub depth_m: f64,
    /// The current motion has arrived: the believed sensor centre (encoders through the
    /// kinematics) is within the tolerance of its target and at rest.
    pub settled: bool,
    /// The current motion's settling time ran out short of its target.
    pub shortfall: Option<Shortfall>,
    pub motion_seq: u64,
    /// Newest tactile frame time and its total force.
    pub tactile_t_s: f64,
    pub contact_n: f64,
    pub tactile_frames: u64,
    pub overruns: u64,
    /// Frames or events the loop had to drop because a consumer lagged.
    pub dropped: u64,
}

impl Default for ControlStatus {
    fn default() -> Self {
        Self {
            t_s: 0.0,
            cycle: 0,
            mode: LoopMode::Disabled,
            position_rad: [0.0; JOINTS],
            velocity_rad_s: [0.0; JOINTS],
            torque_nm: [0.0; JOINTS],
            setpoint_rad: [0.0; JOINTS],
            sensor: SurfacePoint::new(f64::NAN, f64::NAN),
            // No setpoint until the arm is first enabled.
            setpoint: SurfacePoint::new(f64::NAN, f64::NAN),
            depth_m: f64::NAN,
            settled: true,
            shortfall: None,
            motion_seq: 0,
            tactile_t_s: f64::NAN,
            contact_n: f64::NAN,
            tactile_frames: 0,
            overruns: 0,
            dropped: 0,
        }
    }
}

impl Packed for ControlStatus {
    fn pack(&self, out: &mut [u64; SLOT_WORDS]) {
        let mut p = Packer::new(out);
        p.f64(self.t_s)
            .u64(self.cycle)
            .u64(self.mode as u64)
            .f64s(&self.position_rad)
            .f64s(&self.velocity_rad_s)
            .f64s(&self.torque_nm)
            .f64s(&self.setpoint_rad)
            .f64(self.sensor.x_m)
            .f64(self.sensor.z_m)
            .f64(self.setpoint.x_m)
            .f64(self.setpoint.z_m)
            .f64(self.depth_m)
            .u64(u64::from(self.settled))
            .f64(self.shortfall.map_or(f64::NAN, |s| s.distance_m))
            .u64(match self.shortfall.map(|s| s.reason) {
                None => 0,
                Some(ShortfallReason::Stalled) => 1,
                Some(ShortfallReason::NotAtRest) => 2,
            })
            .u64(self.motion_seq)
            .f64(self.tactile_t_s)
            .f64(self.contact_n)
            .u64(self.tactile_frames)
            .u64(self.overruns)
            .u64(self.dropped);
    }

    fn unpack(words: &[u64; SLOT_WORDS]) -> Self {
        let mut u = Unpacker::new(words);
        let t_s = u.f64();
        let cycle = u.u64();
        let mode = match u.u64() {
            1 => LoopMode::Enabled,
            2 => LoopMode::Faulted,
            _ => LoopMode::Disabled,
        };
        Self {
            t_s,
            cycle,
            mode,
            position_rad: u.f64s(),
            velocity_rad_s: u.f64s(),
            torque_nm: u.f64s(),
            setpoint_rad: u.f64s(),
            sensor: SurfacePoint::new(u.f64(), u.f64()),
            setpoint: SurfacePoint::new(u.f64(), u.f64()),
            depth_m: u.f64(),
            settled: u.u64() != 0,
            shortfall: {
                let distance_m = u.f64();
                match u.u64() {
                    1 => Some(ShortfallReason::Stalled),
                    2 => Some(ShortfallReason::NotAtRest),
                    _ => None,
                }
                .map(|reason| Shortfall { distance_m, reason })
            },
            motion_seq: u.u64(),
            tactile_t_s: u.f64(),
            contact_n: u.f64(),
            tactile_frames: u.u64(),
            overruns: u.u64(),
            dropped: u.u64(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_round_trips_through_slot_words() {
        let s = ControlStatus {
            t_s: 12.5,
            cycle: 99,
            mode: LoopMode::Faulted,
            position_rad: [0.1, 0.2, 0.3],
            velocity_rad_s: [1.0, -1.0, 0.5],
            torque_nm: [0.01, 0.02, -0.03],
            setpoint_rad: [0.11, 0.21, 0.31],
            sensor: SurfacePoint::new(0.01, -0.02),
            setpoint: SurfacePoint::new(0.03, 0.04),
            depth_m: 0.3,
            settled: false,
            shortfall: Some(Shortfall {
                distance_m: 0.0096,
                reason: ShortfallReason::Stalled,
            }),
            motion_seq: 17,
            tactile_t_s: 12.49,
            contact_n: 2.5,
            tactile_frames: 1249,
            overruns: 3,
            dropped: 1,
        };
        let mut w = [0u64; SLOT_WORDS];
        s.pack(&mut w);
        assert_eq!(ControlStatus::unpack(&w), s);
    }
}
