//! The tissue-frame procedure in the supervisor (`calibrate tissue`, docs/rig-bring-up.md
//! section 4): the shared touch sequence (`touch_run.rs`) over the named surface points and
//! the two along the artery, then the tissue frame fitted to the touches
//! ([`control::calibration::fit_tissue_frame`]), judged, written to the calibration file and
//! only then handed to the loop.

use std::time::SystemTime;

use nalgebra::Point3;
use serde_json::{Value, json};

use config::calibration_file::{CheckRecord, TissueRecord};
use control::calibration::{ArteryCourse, TissueFit, all_passed, fit_tissue_frame};
use control::frames::SurfacePoint;

use super::touch_run::{TouchProcedure, TouchRun};
use super::*;
use crate::recording::naming::utc_stamp;

impl Supervisor {
    /// `calibrate tissue`: the surface points, then the course's two (if given).
    pub(super) fn tissue_start(
        &mut self,
        id: u64,
        to: Responder,
        points: Vec<SurfacePoint>,
        course: Option<([SurfacePoint; 2], f64)>,
    ) {
        let mut targets = points;
        targets.extend(course.iter().flat_map(|c| c.0));
        let procedure = TouchProcedure::Tissue {
            course: course.map(|c| c.1),
        };
        self.touches_start(id, to, procedure, targets);
    }

    /// Every point is touched: fit, judge, write, and hand the frame to the loop.
    pub(super) fn tissue_finish(&mut self, p: TouchRun, course: Option<f64>) {
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
        let course = match course {
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
            Err(e) => return self.touch_procedure_failed(p.procedure, &e.to_string()),
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
            pivot_in_base_m: self.s.arm.map(|a| a.pivot().pivot_in_base_m),
            joint_zero_rad: Some(self.calibration.joint_zero()),
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
            Err(_) => self.touch_announce(ev, false, None, String::new()),
        }
    }

    /// The loop answered the new placement: in use (and the supervisor's own model with it),
    /// or refused (the file holds it; the next start uses it).
    pub(super) fn tissue_applied(&mut self, refused: Option<String>) {
        let Some((mut ev, record)) = self.tissue_result.take() else {
            return;
        };
        let applied = refused.is_none();
        if applied {
            if let Some(arm) = self.s.arm.as_ref()
                && let Ok(moved) = arm.with_placement(record.placement)
            {
                self.s.arm = Some(moved);
            }
            self.calibration.tissue = Some(record.clone());
        }
        if let (Some(why), Value::Object(o)) = (&refused, &mut ev) {
            o.insert(
                "reason".into(),
                Value::from(format!(
                    "written to the calibration file, but the loop refused it ({why}): it is used from the next start"
                )),
            );
        }
        let line = format!(
            "tissue frame calibrated and in use: yaw {:.2} deg, surface RMS residual {:.3} mm",
            record.placement.yaw_rad.to_degrees(),
            record.rms_residual_m * 1e3
        );
        self.touch_announce(ev, applied, refused.as_deref(), line);
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
