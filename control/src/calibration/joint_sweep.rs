//! The joint stop sweep as the servo loop runs it, one cycle at a time (docs/rig-bring-up.md
//! section 1): it walks a [`SweepPlan`]'s legs, gives the PD law a joint-space setpoint
//! (straight ramps at the sweep speed; during a search the [`StopSearch`]'s slow ramp of one
//! joint, the others held), caps every joint's torque at `sweep_torque_nm`, and says which
//! joint limits the safety check should use: the configured ones, widened by the overtravel
//! (and a little slack) for the stop being swept or backed off only. It reports each stop
//! found, and when it is back where it started. Pure and allocation free: the caller gives
//! the time, the joint state and the torque it commanded.

use thiserror::Error;

use super::joints::{JointSettings, JointsError, Side, StopFound};
use super::stop_search::{SearchStep, StopSearch};
use super::sweep_plan::{Leg, MAX_STOPS, SweepPlan};
use crate::kinematics::JointLimits;
use crate::types::{JOINTS, JointSetpoint, JointState, JointTorques, Joints};

/// Beyond the overtravel, how much more the widened limit allows: a joint stalling at the
/// end of the overtravel overshoots it by a little, rad.
pub const OVERSHOOT_SLACK_RAD: f64 = 0.02;
/// A move has arrived when every joint is this near its target and slower than the stall
/// speed, rad.
pub const ARRIVED_WITHIN_RAD: f64 = 0.01;
/// A move that has not arrived this long after its ramp ended is blocked, s.
pub const MOVE_SETTLE_S: f64 = 3.0;

#[derive(Debug, Clone, PartialEq, Error)]
pub enum SweepError {
    #[error(transparent)]
    Joints(#[from] JointsError),
    #[error(
        "joint {joint} did not reach {target_rad:.4} rad within {MOVE_SETTLE_S} s of its \
         move's end (at {at_rad:.4} rad): something blocks the arm"
    )]
    Blocked {
        joint: usize,
        at_rad: f64,
        target_rad: f64,
    },
}

/// What one cycle of the sweep asks of the loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepCycle {
    /// The joint-space setpoint for the PD law.
    pub setpoint: JointSetpoint,
    /// A stop found this cycle.
    pub found: Option<StopFound>,
    /// Back where the sweep started and at rest: power off.
    pub done: bool,
}

/// The stops a sweep found, in the order found.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Findings {
    found: [Option<StopFound>; MAX_STOPS],
}

impl Findings {
    pub fn iter(&self) -> impl Iterator<Item = &StopFound> {
        self.found.iter().flatten()
    }

    fn push(&mut self, f: StopFound) {
        if let Some(slot) = self.found.iter_mut().find(|s| s.is_none()) {
            *slot = Some(f);
        }
    }
}

/// A ramp under way: where the leg began and when.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LegStart {
    t_s: f64,
    from: Joints,
}

/// A sweep under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSweep {
    plan: SweepPlan,
    settings: JointSettings,
    /// The configured software limits.
    configured: JointLimits,
    leg: usize,
    started: Option<LegStart>,
    search: Option<StopSearch>,
    findings: Findings,
    /// Stopped: going straight home, keeping this stop's check widened.
    aborted: Option<Option<(usize, Side)>>,
    /// The limits the safety check uses this leg.
    checked: JointLimits,
}

impl JointSweep {
    pub fn new(plan: SweepPlan, limits: JointLimits, settings: JointSettings) -> Self {
        let mut s = Self {
            plan,
            settings,
            configured: limits,
            leg: 0,
            started: None,
            search: None,
            findings: Findings::default(),
            aborted: None,
            checked: limits,
        };
        s.widen();
        s
    }

    /// The joint limits the safety layer checks this cycle: the configured ones, widened
    /// past the stop being swept or backed off from.
    pub fn limits(&self) -> &JointLimits {
        &self.checked
    }

    /// The stops found so far.
    pub fn findings(&self) -> Findings {
        self.findings
    }

    pub fn aborted(&self) -> bool {
        self.aborted.is_some()
    }

    /// Every joint's torque within `sweep_torque_nm`.
    pub fn cap(&self, t: &JointTorques) -> JointTorques {
        let mut out = *t;
        for (v, cap) in out.torque_nm.iter_mut().zip(self.settings.sweep_torque_nm) {
            *v = v.clamp(-cap, cap);
        }
        out
    }

    /// Stop looking: go straight back to where the sweep started (at the sweep speed, the
    /// current stop's check still widened), then report done.
    pub fn abort(&mut self) {
        if self.aborted.is_some() {
            return;
        }
        let widened = self.leg().widened();
        self.aborted = Some(widened);
        self.leg = self.plan.legs().len() - 1;
        self.started = None;
        self.search = None;
        self.widen();
    }

    fn leg(&self) -> Leg {
        self.plan.legs()[self.leg]
    }

    fn widen(&mut self) {
        let widened = match self.aborted {
            Some(w) => w,
            None => self.leg().widened(),
        };
        let mut l = self.configured;
        if let Some((j, side)) = widened {
            let by = self.settings.overtravel_rad + OVERSHOOT_SLACK_RAD;
            match side {
                Side::Lower => l.min_rad[j] -= by,
                Side::Upper => l.max_rad[j] += by,
            }
        }
        self.checked = l;
    }

    fn next_leg(&mut self) -> bool {
        self.started = None;
        self.search = None;
        if self.leg + 1 >= self.plan.legs().len() {
            return false;
        }
        self.leg += 1;
        self.widen();
        true
    }

    /// One servo cycle: the measured state and the torque commanded last cycle, N·m.
    pub fn step(
        &mut self,
        state: &JointState,
        last_torque: &JointTorques,
    ) -> Result<SweepCycle, SweepError> {
        if let Some((j, v)) = state
            .position_rad
            .iter()
            .chain(&state.velocity_rad_s)
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            return Err(JointsError::NonFinite {
                joint: j % JOINTS,
                value: *v,
            }
            .into());
        }
        let started = *self.started.get_or_insert(LegStart {
            t_s: state.t_s,
            from: state.position_rad,
        });
        match self.leg() {
            Leg::Move { to, .. } => self.move_step(state, started, &to),
            Leg::Search { joint, side, hold } => {
                let search = match self.search {
                    Some(s) => s,
                    None => StopSearch::new(
                        joint,
                        side,
                        state.position_rad[joint],
                        &self.configured,
                        self.settings,
                    )?,
                };
                let mut search = search;
                let step = search.step(state, last_torque.torque_nm[joint])?;
                self.search = Some(search);
                let mut setpoint = JointSetpoint {
                    position_rad: hold,
                    velocity_rad_s: [0.0; JOINTS],
                };
                match step {
                    SearchStep::Drive { setpoint_rad } => {
                        setpoint.position_rad[joint] = setpoint_rad;
                        if (setpoint_rad - search.end_rad()).abs() > 1e-12 {
                            setpoint.velocity_rad_s[joint] =
                                side.sign() * self.settings.sweep_speed_rad_s;
                        }
                        Ok(SweepCycle {
                            setpoint,
                            found: None,
                            done: false,
                        })
                    }
                    SearchStep::Found(f) => {
                        self.findings.push(f);
                        // Hold where it stopped this cycle; the next leg backs off.
                        setpoint.position_rad[joint] = state.position_rad[joint];
                        self.next_leg();
                        Ok(SweepCycle {
                            setpoint,
                            found: Some(f),
                            done: false,
                        })
                    }
                }
            }
        }
    }

    fn move_step(
        &mut self,
        state: &JointState,
        started: LegStart,
        to: &Joints,
    ) -> Result<SweepCycle, SweepError> {
        let span = to
            .iter()
            .zip(started.from)
            .fold(0.0_f64, |m, (t, f)| m.max((t - f).abs()));
        let duration_s = span / self.settings.sweep_speed_rad_s;
        let elapsed = (state.t_s - started.t_s).max(0.0);
        let mut setpoint = JointSetpoint {
            position_rad: *to,
            velocity_rad_s: [0.0; JOINTS],
        };
        if elapsed < duration_s {
            let f = elapsed / duration_s;
            let sp = &mut setpoint;
            for (j, (t, from)) in to.iter().zip(started.from).enumerate() {
                let d = t - from;
                sp.position_rad[j] = from + f * d;
                sp.velocity_rad_s[j] = d / duration_s;
            }
        } else {
            let arrived = (0..JOINTS).all(|j| {
                (state.position_rad[j] - to[j]).abs() < ARRIVED_WITHIN_RAD
                    && state.velocity_rad_s[j].abs() < self.settings.stall_speed_rad_s
            });
            if arrived {
                let done = !self.next_leg();
                return Ok(SweepCycle {
                    setpoint,
                    found: None,
                    done,
                });
            }
            if elapsed > duration_s + MOVE_SETTLE_S {
                let (joint, _) = (0..JOINTS)
                    .map(|j| (j, (state.position_rad[j] - to[j]).abs()))
                    .fold((0, -1.0), |a, b| if b.1 > a.1 { b } else { a });
                return Err(SweepError::Blocked {
                    joint,
                    at_rad: state.position_rad[joint],
                    target_rad: to[joint],
                });
            }
        }
        Ok(SweepCycle {
            setpoint,
            found: None,
            done: false,
        })
    }
}
