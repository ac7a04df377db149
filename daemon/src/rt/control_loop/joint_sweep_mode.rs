//! The loop's joint-space mode for the joint stop sweep (docs/rig-bring-up.md section 1):
//! with the instrument out of the incision the rod-through-pivot model has no valid pose (at
//! the reset pose the rod would not even reach the pivot), so the sweep powers the arm
//! without it. Each cycle: the joint limits widened for the swept stop only
//! ([`control::calibration::JointSweep::limits`]) and the coupling, the tactile stream's
//! freshness, the sweep's joint-space setpoint through the PD law with the arm's own gravity,
//! every joint capped at `sweep_torque_nm`, then the torque guard. No pose, depth or
//! workspace check: there is no sensor pose to check. Back where it started, the arm is
//! powered off and the supervisor told.

use control::calibration::{JointSettings, JointSweep, StopTargets, SweepError, SweepPlan};
use control::types::{JointState, JointTorques};

use super::ControlLoop;
use crate::rt::fault::{Fault, FaultKind};
use crate::rt::link::{ControlEvent, LoopMode, Refusal};
use crate::rt::safety;

impl ControlLoop {
    /// Power the unpowered arm in joint space and start sweeping `targets` from where it is.
    pub(super) fn start_sweep(
        &mut self,
        now: f64,
        joints: Option<&JointState>,
        targets: StopTargets,
        settings: JointSettings,
    ) -> Result<(), Refusal> {
        let state = &self.joints_to_power(now, joints)?;
        let limits = self.limits.joint_limits;
        let plan = SweepPlan::new(&state.position_rad, targets, &limits, &settings)
            .map_err(|e| Refusal::Cause(e.to_string().into()))?;
        self.tactile_to_power(now)?;
        self.servo.joint_reset();
        if let Err(e) = self.arm.enable() {
            tracing::error!("enabling the arm for the joint sweep: {e}");
            return Err(Refusal::Cause(e.0.into()));
        }
        self.guard.reset();
        self.sweep = Some(JointSweep::new(plan, limits, settings));
        self.status.mode = LoopMode::Enabled;
        self.status.setpoint_rad = state.position_rad;
        self.status.settled = false;
        self.status.shortfall = None;
        Ok(())
    }

    /// `stop` during the sweep: straight back to where it started, then power off.
    pub(super) fn end_sweep(&mut self) -> Result<(), Refusal> {
        match self.sweep.as_mut() {
            Some(s) => {
                s.abort();
                Ok(())
            }
            None => Err(Refusal::Cause("no joint stop sweep is under way".into())),
        }
    }

    /// One cycle of the sweep: its torques, or the fault that ends it.
    pub(super) fn sweep_step(
        &mut self,
        now: f64,
        state: &JointState,
    ) -> Result<JointTorques, Fault> {
        let Some(sweep) = self.sweep.as_mut() else {
            return Ok(JointTorques::ZERO);
        };
        safety::check_joints_within(sweep.limits(), now, state)?;
        safety::check_tactile(
            &self.limits,
            now,
            self.status.tactile_t_s,
            self.status.contact_n,
        )?;
        let last = JointTorques {
            torque_nm: self.status.torque_nm,
        };
        let cycle = sweep.step(state, &last).map_err(|e| sweep_fault(&e, now))?;
        let torques = if cycle.done {
            JointTorques::ZERO
        } else {
            let wanted = self
                .servo
                .joint_step(now, state, &cycle.setpoint, self.dt_s)?;
            self.guard
                .apply(&self.limits, now, self.dt_s, &sweep.cap(&wanted))?
        };
        let (findings, aborted) = (sweep.findings(), sweep.aborted());
        if let Some(found) = cycle.found {
            self.send_event(ControlEvent::StopFound { t_s: now, found });
        }
        if cycle.done {
            self.sweep = None;
            self.power_off();
            self.status.mode = LoopMode::Disabled;
            self.status.settled = true;
            self.send_event(ControlEvent::SweepEnded {
                t_s: now,
                findings,
                aborted,
                at_rad: state.position_rad,
            });
            return Ok(torques);
        }
        self.status.setpoint_rad = cycle.setpoint.position_rad;
        self.status.settled = false;
        Ok(torques)
    }
}

/// A sweep that cannot go on, as a fault with its joint and numbers.
fn sweep_fault(e: &SweepError, now: f64) -> Fault {
    match *e {
        SweepError::Blocked {
            joint,
            at_rad,
            target_rad,
        } => Fault::new(FaultKind::TrackingError, now)
            .on_axis(joint)
            .with_values(at_rad, target_rad)
            .noting("the joint sweep's move is blocked"),
        SweepError::Joints(_) => Fault::new(FaultKind::NonFiniteJoints, now),
    }
}
