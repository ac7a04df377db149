//! The pivot procedure in the supervisor (`calibrate pivot`, docs/rig-bring-up.md section 3):
//! the shared touch sequence (`touch_run.rs`) over five or more points of a level plate
//! spread in `x` and `z`, then the pivot's horizontal place fitted to the touches
//! ([`control::calibration::fit_pivot_level`]: a pivot off to the side makes a level plate
//! read as tilted), judged, written to the calibration file and only then handed to the
//! loop, which holds the arm where it is through the new pivot.

use std::time::SystemTime;

use serde_json::{Value, json};

use config::calibration_file::{CheckRecord, PivotRecord};
use control::calibration::{LevelPivotFit, all_passed, check_layout, fit_pivot_level};
use control::frames::SurfacePoint;

use super::touch_run::{TouchProcedure, TouchRun};
use super::*;
use crate::recording::naming::utc_stamp;

impl Supervisor {
    /// `calibrate pivot`: refuse a layout that cannot fix the pivot before anything moves.
    pub(super) fn pivot_start(&mut self, id: u64, to: Responder, points: Vec<SurfacePoint>) {
        let layout: Vec<[f64; 2]> = points.iter().map(|p| [p.x_m, p.z_m]).collect();
        if let Err(e) = check_layout(&layout) {
            return self.reply_err(id, to, ErrorCode::BadArgument, &format!("`points_m`: {e}"));
        }
        self.touches_start(id, to, TouchProcedure::Pivot, points);
    }

    /// Every point is touched: fit, judge, write, and hand the pivot to the loop.
    pub(super) fn pivot_finish(&mut self, p: TouchRun) {
        let Some(arm) = self.s.arm else {
            return self.touch_procedure_failed(p.procedure, "no kinematic model to fit with");
        };
        let fit = match fit_pivot_level(&arm, &p.touched) {
            Ok(f) => f,
            Err(e) => return self.touch_procedure_failed(p.procedure, &e.to_string()),
        };
        let checks = fit.checks(&self.calibration.settings.tolerances);
        let record = PivotRecord {
            measured_utc: utc_stamp(SystemTime::now()),
            touched_in_tissue_m: p.touched.iter().map(|t| [t.x, t.y, t.z]).collect(),
            placement: p.prior,
            prior_pivot_in_base_m: arm.pivot().pivot_in_base_m,
            pivot_in_base_m: fit.pivot_in_base_m,
            offset_m: fit.offset_m,
            standard_error_m: fit.standard_error_m,
            plate_height_m: fit.plate_height_m,
            rms_residual_m: fit.rms_residual_m,
            max_residual_m: fit.max_residual_m,
            checks: checks.iter().map(CheckRecord::from).collect(),
            passed: all_passed(&checks),
        };
        let saved = if record.passed {
            self.save_calibration("the pivot in use", |f| f.pivot = Some(record.clone()))
        } else {
            Err("a check failed: not written, the pivot in use is unchanged".into())
        };
        let ev = pivot_result(&record, &fit, saved.as_ref().err(), self.now_s());
        match saved {
            Ok(()) => {
                // Announced once the loop has taken it (`pivot_applied`).
                let seq = self.seq();
                self.motion_seq = seq;
                let pivot = fit.apply_to(arm.pivot());
                self.pivot_result = Some((ev, record));
                self.send(
                    ControlCommand::SetPivot { seq, pivot },
                    Purpose::SetPivot,
                    None,
                );
            }
            Err(_) => self.touch_announce(ev, false, None, String::new()),
        }
    }

    /// The loop answered the new pivot: in use (and the supervisor's own model with it), or
    /// refused (the file holds it; the next start uses it).
    pub(super) fn pivot_applied(&mut self, refused: Option<String>) {
        let Some((mut ev, record)) = self.pivot_result.take() else {
            return;
        };
        let applied = refused.is_none();
        if applied {
            if let Some(arm) = self.s.arm.as_ref() {
                let pivot = control::kinematics::PivotGeometry {
                    pivot_in_base_m: record.pivot_in_base_m,
                    ..*arm.pivot()
                };
                if let Ok(moved) = arm.with_pivot(pivot) {
                    self.s.arm = Some(moved);
                }
            }
            self.calibration.pivot = Some(record.clone());
        }
        if let (Some(why), Value::Object(o)) = (&refused, &mut ev) {
            o.insert(
                "reason".into(),
                Value::from(format!(
                    "written to the calibration file, but the loop refused it ({why}): it is used from the next start"
                )),
            );
        }
        let mut line = format!(
            "pivot calibrated and in use: moved ({:+.2}, {:+.2}) mm in base x and z, plate residual RMS {:.3} mm",
            record.offset_m[0] * 1e3,
            record.offset_m[1] * 1e3,
            record.rms_residual_m * 1e3
        );
        self.note_tissue_stale(&mut ev, &mut line);
        self.touch_announce(ev, applied, refused.as_deref(), line);
    }
}

/// The result event, without `applied` (added once known).
fn pivot_result(
    record: &PivotRecord,
    fit: &LevelPivotFit,
    reason: Option<&String>,
    t: f64,
) -> Value {
    json!({"event": "calibration", "t_s": t, "procedure": "pivot", "step": "touch",
        "phase": "done", "passed": record.passed, "reason": reason,
        "pivot_in_base_m": record.pivot_in_base_m,
        "prior_pivot_in_base_m": record.prior_pivot_in_base_m,
        "offset_m": fit.offset_m, "standard_error_m": fit.standard_error_m,
        "plate_height_m": fit.plate_height_m, "rms_residual_m": fit.rms_residual_m,
        "max_residual_m": fit.max_residual_m, "touches": fit.touches,
        "touched_in_tissue_m": record.touched_in_tissue_m, "checks": record.checks})
}
