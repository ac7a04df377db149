//! The touch sequence the tissue-frame and the pivot procedures share (state `calibrating`,
//! docs/rig-bring-up.md sections 3 and 4): for each named point, withdraw the sensor along
//! the rod clear of the surface, cross to above the point, rest there (the force baseline),
//! come down slowly until the surface is felt ([`control::calibration::SurfaceTouch`]) and
//! withdraw again. With every point touched the procedure's own fit takes the touches
//! (`tissue_touch.rs`, `pivot_touch.rs`). Any stop, fault, refusal or a descent that meets
//! nothing ends it with nothing changed.

use nalgebra::Point3;
use serde_json::{Value, json};

use control::calibration::{SurfaceTouch, TouchSettings};
use control::frames::{SurfacePoint, TissuePlacement};

use super::*;

/// A touch must find the surface at least this far below where its baseline was taken:
/// closer, the sensor was already touching at rest.
const MIN_FALL_M: f64 = 1e-3;

/// Which procedure the touches are for, and what it needs beyond them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TouchProcedure {
    /// The tissue frame; with a course, the last two targets are along the artery, whose
    /// line lies at this tissue `z`, m.
    Tissue { course: Option<f64> },
    /// The pivot from touches on a level plate.
    Pivot,
}

impl TouchProcedure {
    pub fn name(&self) -> &'static str {
        match self {
            TouchProcedure::Tissue { .. } => "tissue",
            TouchProcedure::Pivot => "pivot",
        }
    }
}

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

/// A touch sequence under way (state `calibrating`).
pub struct TouchRun {
    pub procedure: TouchProcedure,
    /// The points to touch, tissue frame as believed.
    pub targets: Vec<SurfacePoint>,
    next: usize,
    phase: Phase,
    detector: SurfaceTouch,
    /// The touched surface points, tissue frame as believed during the procedure.
    pub touched: Vec<Point3<f64>>,
    settings: TouchSettings,
    /// The placement the touches are made in.
    pub prior: TissuePlacement,
    /// The pivot (incision), tissue frame: lifts go back along the rod toward it.
    pivot: Point3<f64>,
}

impl TouchRun {
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
    /// Start touching `targets` for `procedure` (its own arguments checked already), or say
    /// why not.
    pub(super) fn touches_start(
        &mut self,
        id: u64,
        to: Responder,
        procedure: TouchProcedure,
        targets: Vec<SurfacePoint>,
    ) {
        let name = procedure.name();
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
        self.touching = Some(TouchRun {
            procedure,
            targets,
            next: 0,
            phase: Phase::Starting,
            detector,
            touched: Vec::with_capacity(n),
            settings,
            prior,
            pivot,
        });
        self.set_state(OpState::Calibrating);
        let t = self.now_s();
        let course = matches!(procedure, TouchProcedure::Tissue { course: Some(_) });
        let ev = json!({"event": "calibration", "t_s": t, "procedure": name,
            "step": "touch", "phase": "started", "points": n, "course": course});
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::INFO,
            format!("calibrating the {name}: touching {n} points"),
        );
        self.reply_ok(
            id,
            to,
            json!({"procedure": name, "step": "touch", "points": n}),
            true,
        );
    }

    fn touch_move(&mut self, target: Point3<f64>, speed_m_s: f64) {
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
    pub(super) fn touch_frame(&mut self, f: &StampedFrame, settled: bool) {
        let force_n = match self.calibration.tactile() {
            Some(c) => c.correct(&f.frame.force_n).iter().flatten().sum(),
            None => f.contact_n,
        };
        let Some(p) = self.touching.as_mut() else {
            return;
        };
        let name = p.procedure.name();
        match touch_step(p, f, force_n, settled) {
            Step::Wait => {}
            Step::Move(to, speed) => {
                let speed = speed.unwrap_or(self.s.move_speed_m_s);
                self.touch_move(to, speed);
            }
            Step::Touched {
                point,
                index,
                up,
                touch,
            } => {
                let t = self.now_s();
                let ev = json!({"event": "calibration", "t_s": t, "procedure": name,
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
                self.touch_move(up, self.s.move_speed_m_s);
            }
            Step::Fail(why) => self.touches_failed(&why),
            Step::Finish => {
                let Some(run) = self.touching.take() else {
                    return;
                };
                self.set_state(OpState::Holding);
                match run.procedure {
                    TouchProcedure::Tissue { course } => self.tissue_finish(run, course),
                    TouchProcedure::Pivot => self.pivot_finish(run),
                }
            }
        }
    }

    /// End the touch sequence under way with nothing changed, holding where the arm is.
    pub(super) fn touches_failed(&mut self, why: &str) {
        let Some(run) = self.touching.take() else {
            return;
        };
        self.touch_procedure_failed(run.procedure, why);
    }

    /// A touch procedure ended without a result (during its touches or in its fit).
    pub(super) fn touch_procedure_failed(&mut self, procedure: TouchProcedure, why: &str) {
        let name = procedure.name();
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": name,
            "step": "touch", "phase": "failed", "reason": why});
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::WARNING,
            format!("{name} calibration: {why} (nothing was changed)"),
        );
        if self.state == OpState::Calibrating {
            let seq = self.seq();
            self.motion_seq = seq;
            self.send(ControlCommand::Hold { seq }, Purpose::TrackerHold, None);
            self.set_state(OpState::Holding);
        }
    }

    /// Publish a touch procedure's result (`applied` or not, with `line` for the log).
    pub(super) fn touch_announce(
        &mut self,
        mut ev: Value,
        applied: bool,
        refused: Option<&str>,
        line: String,
    ) {
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
        let line = if applied {
            line
        } else {
            format!(
                "{} not applied: {}",
                ev["procedure"].as_str().unwrap_or("calibration"),
                refused
                    .or(ev["reason"].as_str())
                    .unwrap_or("a check failed")
            )
        };
        self.log_line(t, if applied { level::INFO } else { level::WARNING }, line);
    }
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

/// The touch sequence's state machine for one frame.
fn touch_step(p: &mut TouchRun, f: &StampedFrame, force_n: f64, settled: bool) -> Step {
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
