//! The tissue-frame procedure in the supervisor (`calibrate tissue`, docs/rig-bring-up.md
//! section 4): for each named point, lift the sensor clear of the surface, cross to above the
//! point, rest there (the force baseline), come down slowly until the surface is felt
//! ([`control::calibration::SurfaceTouch`]) and lift again; then fit the tissue frame to the
//! touches ([`control::calibration::fit_tissue_frame`]), judge it, write it to the
//! calibration file and only then hand it to the loop. Any stop, fault, refusal or a descent
//! that meets nothing ends it with nothing changed.

use std::time::SystemTime;

use nalgebra::Point3;
use serde_json::{Value, json};

use config::calibration_file::{CheckRecord, TissueRecord};
use control::calibration::{
    ArteryCourse, SurfaceTouch, TissueFit, TouchSettings, all_passed, fit_tissue_frame,
};
use control::frames::{SurfacePoint, TissuePlacement};

use super::*;
use crate::recording::naming::utc_stamp;

/// A touch must find the surface at least this far below where its baseline was taken:
/// closer, the sensor was already touching at rest.
const MIN_FALL_M: f64 = 1e-3;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Waiting for a frame to say where the sensor starts from.
    Starting,
    /// Going up to the clearance height (at the start and after each touch).
    Rising,
    /// Crossing to above the next point.
    Crossing,
    /// At rest above it: the detector's baseline.
    Resting,
    /// Coming down onto it.
    Descending,
}

/// A tissue-frame procedure under way (state `calibrating`).
pub struct TissueTouch {
    /// The surface points, then the course's two (if given).
    targets: Vec<SurfacePoint>,
    /// The last two targets are along the artery, whose line lies at this tissue `z`, m.
    course: Option<f64>,
    next: usize,
    phase: Phase,
    detector: SurfaceTouch,
    /// The touched surface points, tissue frame as believed during the procedure.
    touched: Vec<Point3<f64>>,
    settings: TouchSettings,
    /// The placement the touches are made in.
    prior: TissuePlacement,
    /// The pivot (incision), tissue frame: lifts go back along the rod toward it.
    pivot: Point3<f64>,
}

impl TissueTouch {
    fn clearance(&self, at: SurfacePoint) -> Point3<f64> {
        Point3::new(at.x_m, self.settings.clearance_m, at.z_m)
    }

    /// Up to the clearance height from `at` along the rod, as a surgeon withdraws an
    /// instrument: a straight-up lift would drag the pressed tip sideways against the
    /// tissue's friction (on the seed's compliant rod the arm stops short doing so).
    fn withdrawn(&self, at: Point3<f64>) -> Point3<f64> {
        let u = self.pivot - at;
        let rise = self.settings.clearance_m - at.y;
        match u.try_normalize(1e-9) {
            Some(u) if u.y > 0.1 && rise > 0.0 => at + u * (rise / u.y),
            _ => self.clearance(SurfacePoint::new(at.x, at.z)),
        }
    }
}

impl Supervisor {
    /// `calibrate tissue`: check the points and start.
    pub(super) fn tissue_start(
        &mut self,
        id: u64,
        to: Responder,
        points: Vec<SurfacePoint>,
        course: Option<([SurfacePoint; 2], f64)>,
    ) {
        let Some((prior, pivot)) = self.s.arm.as_ref().map(|a| {
            let pivot = control::kinematics::pivot::pivot_point(a.pivot()).0;
            (*a.placement(), a.placement().to_tissue(&pivot))
        }) else {
            return self.reply_err(
                id,
                to,
                ErrorCode::Unavailable,
                "this daemon has no kinematic model to place the touches with",
            );
        };
        let mut targets = points;
        targets.extend(course.iter().flat_map(|c| c.0));
        if let Some((i, p)) = targets
            .iter()
            .enumerate()
            .find(|(_, p)| !self.in_workspace(**p))
        {
            return self.reply_err(
                id,
                to,
                ErrorCode::Refused,
                &format!(
                    "point {i} ({:.1}, {:.1}) mm lies outside the workspace (safety.workspace_x_m, workspace_z_m)",
                    p.x_m * 1e3,
                    p.z_m * 1e3
                ),
            );
        }
        let settings = self.calibration.settings.touch;
        let detector = match SurfaceTouch::new(settings) {
            Ok(d) => d,
            Err(e) => return self.reply_err(id, to, ErrorCode::Refused, &e),
        };
        let n = targets.len();
        let procedure = TissueTouch {
            targets,
            course: course.map(|c| c.1),
            next: 0,
            phase: Phase::Starting,
            detector,
            touched: Vec::with_capacity(n),
            settings,
            prior,
            pivot,
        };
        self.tissue = Some(procedure);
        self.set_state(OpState::Calibrating);
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "tissue",
            "step": "touch", "phase": "started", "points": n, "course": course.is_some()});
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::INFO,
            format!("calibrating the tissue frame: touching {n} points"),
        );
        self.reply_ok(
            id,
            to,
            json!({"procedure": "tissue", "step": "touch", "points": n}),
            true,
        );
    }

    fn tissue_move(&mut self, target: Point3<f64>, speed_m_s: f64) {
        let seq = self.seq();
        self.motion_seq = seq;
        self.send(
            ControlCommand::MoveToPoint {
                seq,
                target,
                speed_m_s: speed_m_s.min(self.s.max_speed_m_s),
            },
            Purpose::CalibrationMove,
            None,
        );
    }

    /// One frame while touching: the raw force (as the tactile calibration in use reads it,
    /// skipping its unusable elements) and the sensor's believed height.
    pub(super) fn tissue_frame(&mut self, f: &StampedFrame, settled: bool) {
        let force_n = match self.calibration.tactile() {
            Some(c) => c.correct(&f.frame.force_n).iter().flatten().sum(),
            None => f.contact_n,
        };
        let Some(p) = self.tissue.as_mut() else {
            return;
        };
        match tissue_step(p, f, force_n, settled) {
            Step::Wait => {}
            Step::Move(to, speed) => {
                let speed = speed.unwrap_or(self.s.move_speed_m_s);
                self.tissue_move(to, speed);
            }
            Step::Touched {
                point,
                index,
                up,
                touch,
            } => {
                let t = self.now_s();
                let ev = json!({"event": "calibration", "t_s": t, "procedure": "tissue",
                    "step": "touch", "phase": "touched", "point": index,
                    "at_m": [point.x, point.y, point.z],
                    "stiffness_n_per_m": touch.stiffness_n_per_m, "frames": touch.samples,
                    "rms_residual_n": touch.rms_residual_n,
                    "baseline_sd_n": touch.baseline_sd_n});
                self.publish(Stream::Calibration, 0, &ev, false);
                self.log_line(
                    t,
                    level::INFO,
                    format!(
                        "touched point {index}: the surface {:.2} mm from the configured one at ({:.1}, {:.1}) mm",
                        point.y * 1e3,
                        point.x * 1e3,
                        point.z * 1e3
                    ),
                );
                self.tissue_move(up, self.s.move_speed_m_s);
            }
            Step::Fail(why) => self.tissue_failed(&why),
            Step::Finish => self.tissue_finish(),
        }
    }

    /// End the procedure with nothing changed, holding where the arm is.
    pub(super) fn tissue_failed(&mut self, why: &str) {
        if self.tissue.take().is_none() {
            return;
        }
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "tissue",
            "step": "touch", "phase": "failed", "reason": why});
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::WARNING,
            format!("tissue calibration: {why} (nothing was changed)"),
        );
        if self.state == OpState::Calibrating {
            let seq = self.seq();
            self.motion_seq = seq;
            self.send(ControlCommand::Hold { seq }, Purpose::TrackerHold, None);
            self.set_state(OpState::Holding);
        }
    }

    fn tissue_finish(&mut self) {
        let Some(p) = self.tissue.take() else {
            return;
        };
        self.set_state(OpState::Holding);
        let mut base: Vec<Point3<f64>> = p.touched.iter().map(|t| p.prior.to_base(t)).collect();
        // The course's two touches fix the yaw only, at the points the operator named (where
        // the marks are; a low-gain arm pressing on a tilted rod comes down a few millimetres
        // from them). Over the artery the pulsing tube lifts the surface it is felt at (2 mm
        // on the simulator's 100 kPa tube), so they are kept out of the plane.
        let named = |i: usize| {
            p.targets
                .get(i)
                .map(|t| p.prior.to_base(&Point3::new(t.x_m, 0.0, t.z_m)))
        };
        let n = p.targets.len();
        let course = match p.course {
            Some(lateral_m) if base.len() == n && n >= 5 => {
                base.truncate(n - 2);
                named(n - 2)
                    .zip(named(n - 1))
                    .map(|(from, to)| ArteryCourse {
                        from,
                        to,
                        lateral_m,
                    })
            }
            _ => None,
        };
        let fit = match fit_tissue_frame(&base, course.as_ref(), &p.prior) {
            Ok(f) => f,
            Err(e) => {
                self.tissue = Some(p);
                return self.tissue_failed(&e.to_string());
            }
        };
        let checks = fit.checks(&self.calibration.settings.tolerances);
        let record = TissueRecord {
            measured_utc: utc_stamp(SystemTime::now()),
            surface_in_base_m: base.iter().map(|b| [b.x, b.y, b.z]).collect(),
            course_in_base_m: course.map(|c| [c.from.into(), c.to.into()]),
            course_lateral_m: course.map_or(0.0, |c| c.lateral_m),
            prior: p.prior,
            placement: fit.placement,
            tilt_rad: fit.tilt_rad,
            rms_residual_m: fit.rms_residual_m,
            max_residual_m: fit.max_residual_m,
            checks: checks.iter().map(CheckRecord::from).collect(),
            passed: all_passed(&checks),
        };
        let saved = if record.passed {
            self.save_tissue(&record)
        } else {
            Err("a check failed: not written, the tissue frame in use is unchanged".into())
        };
        let t = self.now_s();
        let ev = tissue_result(&record, &fit, saved.as_ref().err(), t);
        match saved {
            Ok(()) => {
                // Announced once the loop has taken it (`tissue_applied`).
                let seq = self.seq();
                self.motion_seq = seq;
                let placement = record.placement;
                self.tissue_result = Some((ev, record));
                self.send(
                    ControlCommand::SetPlacement { seq, placement },
                    Purpose::SetPlacement,
                    None,
                );
            }
            Err(_) => self.tissue_announce(ev, false, None),
        }
    }

    /// The loop answered the new placement: in use (and the supervisor's own model with it),
    /// or refused (the file holds it; the next start uses it).
    pub(super) fn tissue_applied(&mut self, refused: Option<String>) {
        let Some((mut ev, record)) = self.tissue_result.take() else {
            return;
        };
        if refused.is_none() {
            if let Some(arm) = self.s.arm.as_ref()
                && let Ok(moved) = arm.with_placement(record.placement)
            {
                self.s.arm = Some(moved);
            }
            self.calibration.tissue = Some(record);
        }
        if let (Some(why), Value::Object(o)) = (&refused, &mut ev) {
            o.insert(
                "reason".into(),
                Value::from(format!(
                    "written to the calibration file, but the loop refused it ({why}): it is used from the next start"
                )),
            );
        }
        self.tissue_announce(ev, refused.is_none(), refused);
    }

    fn tissue_announce(&mut self, mut ev: Value, applied: bool, refused: Option<String>) {
        let t = self.now_s();
        if let Value::Object(o) = &mut ev {
            o.insert("applied".into(), Value::from(applied));
            o.insert("t_s".into(), Value::from(t));
            if applied {
                o.insert("file".into(), json!(self.calibration.settings.file));
            }
        }
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
        let yaw = ev["placement"]["yaw_rad"].as_f64().unwrap_or(f64::NAN);
        let line = if applied {
            format!(
                "tissue frame calibrated and in use: yaw {:.2} deg, surface RMS residual {:.3} mm",
                yaw.to_degrees(),
                ev["rms_residual_m"].as_f64().unwrap_or(f64::NAN) * 1e3
            )
        } else {
            format!(
                "tissue frame not applied: {}",
                refused
                    .as_deref()
                    .or(ev["reason"].as_str())
                    .unwrap_or("a check failed")
            )
        };
        self.log_line(t, if applied { level::INFO } else { level::WARNING }, line);
    }

    /// Write `record` into the calibration file (keeping what else it holds).
    fn save_tissue(&self, record: &TissueRecord) -> Result<(), String> {
        self.save_calibration("the tissue frame in use", |f| {
            f.tissue = Some(record.clone())
        })
    }
}

/// The result event, without `applied` (added once known).
fn tissue_result(record: &TissueRecord, fit: &TissueFit, reason: Option<&String>, t: f64) -> Value {
    json!({"event": "calibration", "t_s": t, "procedure": "tissue", "step": "touch",
        "phase": "done", "passed": record.passed, "reason": reason,
        "placement": record.placement, "prior": record.prior,
        "yaw_change_rad": record.placement.yaw_rad - record.prior.yaw_rad,
        "origin_change_m": std::array::from_fn::<f64, 3, _>(|i|
            record.placement.origin_in_base_m[i] - record.prior.origin_in_base_m[i]),
        "tilt_rad": fit.tilt_rad, "rms_residual_m": fit.rms_residual_m,
        "max_residual_m": fit.max_residual_m, "worst_point": fit.worst_point,
        "yaw_from": match fit.yaw_from {
            control::calibration::YawSource::ArteryCourse => "artery_course",
            control::calibration::YawSource::Prior => "prior",
        },
        "surface_in_base_m": record.surface_in_base_m, "checks": record.checks})
}

/// What the procedure does next.
enum Step {
    Wait,
    /// Move there (at the descent speed if given, else the move speed).
    Move(Point3<f64>, Option<f64>),
    Touched {
        point: Point3<f64>,
        index: usize,
        up: Point3<f64>,
        touch: control::calibration::Touch,
    },
    Fail(String),
    Finish,
}

/// The procedure's state machine for one frame.
fn tissue_step(p: &mut TissueTouch, f: &StampedFrame, force_n: f64, settled: bool) -> Step {
    let Some(target) = p.targets.get(p.next).copied() else {
        // Every point is touched: the last lift must come to rest before the fit.
        return if settled { Step::Finish } else { Step::Wait };
    };
    match p.phase {
        Phase::Starting => {
            let here = Point3::new(f.sensor.x_m, f.height_m, f.sensor.z_m);
            if !here.iter().all(|v| v.is_finite()) {
                return Step::Wait;
            }
            p.phase = Phase::Rising;
            Step::Move(p.withdrawn(here), None)
        }
        Phase::Rising if settled => {
            p.phase = Phase::Crossing;
            Step::Move(p.clearance(target), None)
        }
        Phase::Crossing if settled => match SurfaceTouch::new(p.settings) {
            Ok(d) => {
                p.detector = d;
                p.phase = Phase::Resting;
                Step::Wait
            }
            Err(e) => Step::Fail(e),
        },
        Phase::Resting => {
            if let Some(Err(e)) = p.detector.push(f.height_m, force_n) {
                return Step::Fail(format!("point {}: {e}", p.next));
            }
            if !p.detector.ready() {
                return Step::Wait;
            }
            p.phase = Phase::Descending;
            let bottom = Point3::new(target.x_m, -p.settings.search_depth_m, target.z_m);
            Step::Move(bottom, Some(p.settings.descent_speed_m_s))
        }
        Phase::Descending => {
            let result = match p.detector.push(f.height_m, force_n) {
                Some(r) => r,
                // The descent went as deep as it may: a surface if the force rose enough.
                None if settled => p.detector.finish(),
                None => return Step::Wait,
            };
            let index = p.next;
            match result {
                Ok(touch)
                    if touch.rest_height_m.is_nan()
                        || touch.surface_height_m >= touch.rest_height_m - MIN_FALL_M =>
                {
                    Step::Fail(format!(
                        "point {index}: the sensor was on the tissue already while it rested, {:+.2} mm from the configured surface instead of {:+.1} mm above it: the arm could not lift it clear (an added mass the drive does not carry? take it off for the procedure), or the surface is higher than calibration.tissue.clearance_m",
                        touch.rest_height_m * 1e3,
                        p.settings.clearance_m * 1e3
                    ))
                }
                Ok(touch) => {
                    let point = Point3::new(f.sensor.x_m, touch.surface_height_m, f.sensor.z_m);
                    p.touched.push(point);
                    p.next += 1;
                    p.phase = Phase::Rising;
                    let here = Point3::new(f.sensor.x_m, f.height_m, f.sensor.z_m);
                    Step::Touched {
                        point,
                        index,
                        up: p.withdrawn(here),
                        touch,
                    }
                }
                Err(e) => Step::Fail(format!(
                    "point {index} ({:.1}, {:.1}) mm: {e} (calibration.tissue.search_depth_m: {:.1} mm below the configured surface)",
                    target.x_m * 1e3,
                    target.z_m * 1e3,
                    p.settings.search_depth_m * 1e3
                )),
            }
        }
        Phase::Rising | Phase::Crossing => Step::Wait,
    }
}
