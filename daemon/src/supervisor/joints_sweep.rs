//! The joint stop sweep in the supervisor (`calibrate joints sweep`, docs/rig-bring-up.md
//! section 1): with the arm resting unpowered in its reset pose, the instrument out of the
//! incision and a homing in use, the loop powers the arm in joint space and sweeps each
//! named joint slowly to both its stops with a capped torque
//! (`rt/control_loop/joint_sweep_mode.rs`), then brings it back and powers off. The stops it
//! found are judged against the configured software limits, written atomically into the
//! calibration file's `joints` record and only then announced. A stop inside its software
//! limit is reported as such (the result, the log, `status`); the software limit is *not*
//! narrowed to it: the limits stay the config's, which a person corrects. `stop` brings the
//! arm back where it started and powers off with nothing written; `disable` or a fault
//! powers off at once, nothing written.

use std::time::SystemTime;

use serde_json::{Value, json};

use config::calibration_file::{CheckRecord, StopRecord};
use control::calibration::{Findings, Leg, StopFound, StopTargets, SweepPlan, all_passed};
use control::kinematics::JointLimits;

use super::*;
use crate::recording::naming::utc_stamp;

/// A sweep under way (state `calibrating`).
#[derive(Debug, Clone)]
pub struct SweepRun {
    targets: StopTargets,
    /// The sweep's length at the sweep speed (moves and searches, no stalls), s.
    estimate_s: f64,
    found: Vec<StopFound>,
}

/// A person's line for each stop that lies inside its software limit (empty: none does).
pub fn inside_limits(stops: &[StopRecord]) -> Vec<String> {
    stops
        .iter()
        .filter(|s| s.stalled && s.margin_rad < 0.0)
        .map(|s| {
            format!(
                "joint {} {} stop at {:.3} deg lies {:.3} deg inside its software limit {:.3} deg \
                 (robot.joint_limits): the arm can be commanded into it; set the limit inside the \
                 stop and sweep again",
                s.joint,
                s.side.name(),
                s.at_rad.to_degrees(),
                -s.margin_rad.to_degrees(),
                s.software_limit_rad.to_degrees()
            )
        })
        .collect()
}

/// How long the plan takes at `speed`, s.
fn estimate_s(plan: &SweepPlan, limits: &JointLimits, overtravel_rad: f64, speed: f64) -> f64 {
    let mut at = plan.start();
    let mut total = 0.0;
    for leg in plan.legs() {
        let to = match *leg {
            Leg::Move { to, .. } => to,
            Leg::Search { joint, side, hold } => {
                let mut end = hold;
                end[joint] = side.limit(limits, joint) + side.sign() * overtravel_rad;
                end
            }
        };
        let span = (0..3).map(|j| (to[j] - at[j]).abs()).fold(0.0, f64::max);
        total += span / speed;
        at = to;
    }
    total
}

impl Supervisor {
    /// `calibrate joints sweep`: check, plan, and hand the sweep to the loop.
    pub(super) fn joints_sweep(&mut self, id: u64, to: Responder, joints: &[usize]) {
        let refuse = |s: &Self, to, code, why: &str| s.reply_err(id, to, code, why);
        if self.state != OpState::Disabled {
            return refuse(
                self,
                to,
                ErrorCode::WrongState,
                "the sweep starts from the unpowered arm resting in its reset pose: `disable` first, then put it against its reset fixture",
            );
        }
        if self.sweeping.is_some() || self.joints_result.is_some() {
            return refuse(
                self,
                to,
                ErrorCode::WrongState,
                "a joints calibration is under way; wait for its result",
            );
        }
        if self.calibration.joints.is_none() {
            return refuse(
                self,
                to,
                ErrorCode::Refused,
                "the sweep needs the encoder zero first: run `calibrate joints home` (its stops are read through it)",
            );
        }
        let targets = match StopTargets::joints(joints) {
            Ok(t) if t.count() > 0 => t,
            Ok(_) => StopTargets::all(),
            Err(e) => return refuse(self, to, ErrorCode::BadArgument, &format!("`joints`: {e}")),
        };
        let st = match self.joints_at_rest() {
            Ok(st) => st,
            Err((code, why)) => return refuse(self, to, code, &why),
        };
        let settings = self.calibration.settings.joints;
        let limits = self.calibration.settings.joint_limits;
        let plan = match SweepPlan::new(&st.position_rad, targets, &limits, &settings) {
            Ok(p) => p,
            Err(e) => return refuse(self, to, ErrorCode::Refused, &e.to_string()),
        };
        self.sweeping = Some(SweepRun {
            targets,
            estimate_s: estimate_s(
                &plan,
                &limits,
                settings.overtravel_rad,
                settings.sweep_speed_rad_s,
            ),
            found: Vec::new(),
        });
        let seq = self.seq();
        self.send(
            ControlCommand::SweepStops {
                seq,
                targets,
                settings,
            },
            Purpose::SweepStart,
            Some((id, to)),
        );
    }

    /// The request's answer once the loop has powered the arm.
    pub(super) fn sweep_reply(&self) -> Value {
        let Some(run) = &self.sweeping else {
            return json!({});
        };
        json!({"procedure": "joints", "step": "sweep", "stops": run.targets.count(),
            "duration_s": run.estimate_s})
    }

    /// The loop powered the arm and the sweep runs.
    pub(super) fn sweep_started(&mut self) {
        self.set_state(OpState::Calibrating);
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "joints",
            "step": "sweep", "phase": "started",
            "stops": self.sweeping.as_ref().map_or(0, |r| r.targets.count())});
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
    }

    pub(super) fn sweep_found(&mut self, t: f64, found: StopFound) {
        let Some(run) = self.sweeping.as_mut() else {
            return;
        };
        run.found.push(found);
        let limits = self.calibration.settings.joint_limits;
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "joints",
            "step": "sweep", "phase": "stop_found", "joint": found.joint, "side": found.side,
            "at_rad": found.at_rad, "stalled": found.stalled,
            "margin_rad": found.margin_rad(&limits)});
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
    }

    /// `stop` during the sweep: the loop takes the arm straight back where it started and
    /// powers off; the result says `stopped`, nothing written.
    pub(super) fn sweep_stop(&mut self, id: u64, to: Responder) {
        let seq = self.seq();
        self.send(
            ControlCommand::EndSweep { seq },
            Purpose::SweepStop,
            Some((id, to)),
        );
    }

    /// The sweep ended without a result (`disable`, a fault): nothing was written.
    pub(super) fn sweep_failed(&mut self, why: &str) {
        if self.sweeping.take().is_none() {
            return;
        }
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "joints",
            "step": "sweep", "phase": "failed", "reason": why});
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::WARNING,
            format!("joint stop sweep: {why} (nothing was changed)"),
        );
    }

    /// The loop is back where the sweep started, the arm unpowered: judge, write, announce.
    pub(super) fn sweep_ended(&mut self, findings: Findings, aborted: bool, at_rad: [f64; 3]) {
        if self.state == OpState::Calibrating {
            self.set_state(OpState::Disabled);
        }
        if aborted {
            let back = at_rad.map(f64::to_degrees);
            return self.sweep_failed(&format!(
                "stopped: the arm went back where it started, at ({:.2}, {:.2}, {:.2}) deg, and was powered off",
                back[0], back[1], back[2]
            ));
        }
        let Some(_run) = self.sweeping.take() else {
            return;
        };
        let Some(mut record) = self.calibration.joints.clone() else {
            return;
        };
        let limits = self.calibration.settings.joint_limits;
        let settings = self.calibration.settings.joints;
        let mut checks = Vec::new();
        let mut stops = Vec::new();
        for f in findings.iter() {
            stops.push(StopRecord {
                joint: f.joint,
                side: f.side,
                at_rad: f.at_rad,
                stalled: f.stalled,
                software_limit_rad: f.side.limit(&limits, f.joint),
                margin_rad: f.margin_rad(&limits),
            });
            if let Ok(c) = f.check(&limits, &settings) {
                checks.push(c);
            }
        }
        let passed = all_passed(&checks);
        record.stops = stops;
        record.stop_checks = checks.iter().map(CheckRecord::from).collect();
        record.stops_measured_utc = Some(utc_stamp(SystemTime::now()));
        let inside = inside_limits(&record.stops);
        let saved = self.save_calibration("the stops on file", |f| f.joints = Some(record.clone()));
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "joints",
            "step": "sweep", "phase": "done", "passed": passed,
            "reason": saved.as_ref().err(), "stops": record.stops,
            "checks": record.stop_checks, "stops_inside_limits": inside,
            "software_limits_narrowed": false});
        let applied = saved.is_ok();
        if applied {
            self.calibration.joints = Some(record.clone());
        }
        let mut line = format!(
            "joint stops found and written: {}",
            record
                .stops
                .iter()
                .map(|s| format!(
                    "joint {} {} {:.2} deg ({:+.2} deg beyond the limit)",
                    s.joint,
                    s.side.name(),
                    s.at_rad.to_degrees(),
                    s.margin_rad.to_degrees()
                ))
                .collect::<Vec<_>>()
                .join(", ")
        );
        for l in &inside {
            line.push_str("; ");
            line.push_str(l);
        }
        self.touch_announce(ev, applied, None, line);
    }
}
