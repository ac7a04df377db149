//! The joints' homing in the supervisor (`calibrate joints home`, docs/rig-bring-up.md
//! section 1): the unpowered arm rests in its reset pose with the instrument out of the
//! incision; the encoders' angles there against the reset pose's known angles give each
//! joint's zero offset ([`control::calibration::zero_offsets`]), judged, written to the
//! calibration file and only then handed to the loop, which adds it to every angle it reads.
//! A new homing clears the stops a sweep found (`joints_sweep.rs`): they were read through
//! the old zero.

use std::time::SystemTime;

use serde_json::{Value, json};

use config::calibration_file::{CheckRecord, JointsRecord};
use control::calibration::{all_passed, zero_checks, zero_offsets};

use super::*;
use crate::recording::naming::utc_stamp;

impl Supervisor {
    /// `calibrate joints home`: read, judge, write, and hand the zero to the loop.
    pub(super) fn joints_home(&mut self, id: u64, to: Responder) {
        if self.state != OpState::Disabled {
            return self.reply_err(
                id,
                to,
                ErrorCode::WrongState,
                "the homing reads the unpowered arm resting in its reset pose: `disable` first, then put it against its reset fixture",
            );
        }
        if self.joints_result.is_some() {
            return self.reply_err(
                id,
                to,
                ErrorCode::WrongState,
                "a joints calibration is being applied; wait for its result",
            );
        }
        let st = match self.joints_at_rest() {
            Ok(st) => st,
            Err((code, why)) => return self.reply_err(id, to, code, &why),
        };
        let settings = self.calibration.settings.joints;
        // The angles as the encoders give them, before the offset in use.
        let in_use = self.calibration.joint_zero();
        let mut read = st.position_rad;
        for (q, o) in read.iter_mut().zip(in_use) {
            *q -= o;
        }
        let offset = match zero_offsets(&settings.reset_pose_rad, &read) {
            Ok(o) => o,
            Err(e) => return self.reply_err(id, to, ErrorCode::Unavailable, &e.to_string()),
        };
        let checks = zero_checks(&offset, &settings);
        let record = JointsRecord {
            measured_utc: utc_stamp(SystemTime::now()),
            reset_pose_rad: settings.reset_pose_rad,
            read_rad: read,
            zero_offset_rad: offset,
            stops: Vec::new(),
            checks: checks.iter().map(CheckRecord::from).collect(),
            passed: all_passed(&checks),
            stops_measured_utc: None,
            stop_checks: Vec::new(),
        };
        self.reply_ok(
            id,
            to,
            json!({"procedure": "joints", "step": "home", "read_rad": read}),
            false,
        );
        let saved = if record.passed {
            self.save_calibration("the encoder zero in use", |f| {
                f.joints = Some(record.clone())
            })
        } else {
            Err("a check failed: not written, the encoder zero in use is unchanged".into())
        };
        let ev = joints_result(&record, in_use, saved.as_ref().err(), self.now_s());
        match saved {
            Ok(()) => {
                // Announced once the loop has taken it (`joints_applied`).
                let seq = self.seq();
                self.joints_result = Some((ev, record.clone()));
                self.send(
                    ControlCommand::SetJointZero {
                        seq,
                        offset_rad: record.zero_offset_rad,
                    },
                    Purpose::SetJointZero,
                    None,
                );
            }
            Err(_) => self.touch_announce(ev, false, None, String::new()),
        }
    }

    /// The loop's last report of the arm, once every joint rests (slower than
    /// `calibration.joints.stall_speed_rad_s`): the homing and the sweep both start from the
    /// arm at rest against its reset fixture.
    pub(super) fn joints_at_rest(&self) -> Result<ControlStatus, (ErrorCode, String)> {
        let Some(st) = self.links.status.read() else {
            return Err((
                ErrorCode::Unavailable,
                "the control loop has not reported the joints yet".into(),
            ));
        };
        let stall = self.calibration.settings.joints.stall_speed_rad_s;
        match st
            .velocity_rad_s
            .iter()
            .enumerate()
            .find(|(_, v)| v.is_nan() || v.abs() >= stall)
        {
            Some((j, v)) => Err((
                ErrorCode::Refused,
                format!(
                    "joint {j} is moving ({v:.4} rad/s, calibration.joints.stall_speed_rad_s {stall}): the arm must rest against its reset fixture"
                ),
            )),
            None => Ok(st),
        }
    }

    /// The loop answered the new zero: in use, or refused (the file holds it; the next start
    /// uses it).
    pub(super) fn joints_applied(&mut self, refused: Option<String>) {
        let Some((mut ev, record)) = self.joints_result.take() else {
            return;
        };
        let applied = refused.is_none();
        if applied {
            self.calibration.joints = Some(record.clone());
        }
        if let (Some(why), Value::Object(o)) = (&refused, &mut ev) {
            o.insert(
                "reason".into(),
                Value::from(format!(
                    "written to the calibration file, but the loop refused it ({why}): it is used from the next start"
                )),
            );
        }
        let deg = record.zero_offset_rad.map(f64::to_degrees);
        let mut line = format!(
            "encoder zero calibrated and in use: offsets ({:+.3}, {:+.3}, {:+.3}) deg",
            deg[0], deg[1], deg[2]
        );
        self.note_tissue_stale(&mut ev, &mut line);
        self.touch_announce(ev, applied, refused.as_deref(), line);
    }
}

/// The result event, without `applied` (added once known).
fn joints_result(
    record: &JointsRecord,
    prior_offset_rad: [f64; 3],
    reason: Option<&String>,
    t: f64,
) -> Value {
    json!({"event": "calibration", "t_s": t, "procedure": "joints", "step": "home",
        "phase": "done", "passed": record.passed, "reason": reason,
        "reset_pose_rad": record.reset_pose_rad, "read_rad": record.read_rad,
        "zero_offset_rad": record.zero_offset_rad, "prior_zero_offset_rad": prior_offset_rad,
        "stops": record.stops, "checks": record.checks})
}
