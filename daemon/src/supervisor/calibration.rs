//! The tactile array's calibration in the supervisor: the `calibrate` verb's recordings
//! (a tare with nothing on the array, then a known load), the result judged against the
//! configured tolerances, written to the calibration file when it passes and only then
//! applied: every frame a tracker sees is corrected by it, and each new tracker skips its
//! unusable elements. A result is announced as applied only once the file is on disk.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use config::calibration_file::{
    self, CalibrationFile, CheckRecord, JointsRecord, PivotRecord, TactileRecord, TissueRecord,
};
use control::calibration::{TactileCalibration, TactileSettings, Tare, Tolerances, all_passed};
use control::sensor::ArrayGeometry;
use control::types::TactileFrame;

use super::Supervisor;
use crate::backend::ArrayBench;
use crate::console::hub::Responder;
use crate::console::protocol::{CalibrateStep, ErrorCode, Stream};
use crate::recording::foxglove_msgs::level;
use crate::recording::naming::utc_stamp;
use crate::recording::topics::Topic;

/// Wall time a recording may overrun its length before it fails for want of frames.
const FRAME_GRACE: Duration = Duration::from_secs(5);

/// The calibration's settings, from config.
#[derive(Debug, Clone)]
pub struct CalibrationSettings {
    /// The calibration file (read at start, rewritten when a procedure passes).
    pub file: PathBuf,
    pub tolerances: Tolerances,
    pub tactile: TactileSettings,
    /// Default length of a tactile recording, s.
    pub tactile_recording_s: f64,
    /// The tissue frame's touches.
    pub touch: control::calibration::TouchSettings,
    /// The array as configured, before any calibration.
    pub sensor: ArrayGeometry,
    /// The simulated clock's speed against the wall (1 on hardware).
    pub time_scale: f64,
    /// The joints' homing and stop sweep: the reset pose, the sweep, the pass limits.
    pub joints: control::calibration::JointSettings,
    /// The configured software limits the sweep's stops are judged against.
    pub joint_limits: control::kinematics::JointLimits,
}

/// A recording under way.
struct Recording {
    step: CalibrateStep,
    frames: Vec<TactileFrame>,
    wanted: usize,
    deadline: Instant,
}

/// The calibration's state.
pub struct Calibration {
    pub settings: CalibrationSettings,
    /// The tactile calibration in use (a record that passed, from the file or a procedure).
    applied: Option<TactileRecord>,
    /// The tissue frame in use, if a calibration placed it.
    pub(super) tissue: Option<TissueRecord>,
    /// The pivot in use, if a calibration found it.
    pub(super) pivot: Option<PivotRecord>,
    /// The encoder zero in use, if a homing measured it.
    pub(super) joints: Option<JointsRecord>,
    tare: Option<Tare>,
    recording: Option<Recording>,
    bench: Option<Box<dyn ArrayBench>>,
}

impl std::fmt::Debug for Calibration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Calibration")
            .field("file", &self.settings.file)
            .field("applied", &self.applied.is_some())
            .finish()
    }
}

/// Why the file's tactile record cannot be applied, if it cannot.
pub fn usable_record(
    record: &TactileRecord,
    sensor: &ArrayGeometry,
) -> Result<ArrayGeometry, String> {
    if !record.passed {
        return Err(format!(
            "its tactile calibration of {} did not pass its checks",
            record.measured_utc
        ));
    }
    record.calibration.geometry(sensor)
}

/// The pivot of the file's pivot record, if the daemon may use it (it passed its checks).
pub fn usable_pivot(record: &PivotRecord) -> Result<[f64; 3], String> {
    if record.passed {
        Ok(record.pivot_in_base_m)
    } else {
        Err(format!(
            "its pivot of {} did not pass its checks",
            record.measured_utc
        ))
    }
}

/// The zero offset of the file's joints record, if the daemon may use it (it passed its
/// checks).
pub fn usable_joints(record: &JointsRecord) -> Result<[f64; 3], String> {
    if record.passed {
        Ok(record.zero_offset_rad)
    } else {
        Err(format!(
            "its joints calibration of {} did not pass its checks",
            record.measured_utc
        ))
    }
}

/// The placement of the file's tissue record, if the daemon may use it (it passed its checks).
pub fn usable_tissue(record: &TissueRecord) -> Result<control::frames::TissuePlacement, String> {
    if record.passed {
        Ok(record.placement)
    } else {
        Err(format!(
            "its tissue frame of {} did not pass its checks",
            record.measured_utc
        ))
    }
}

impl Calibration {
    /// With the file's tactile record applied (`applied` must pass [`usable_record`]).
    pub fn new(
        settings: CalibrationSettings,
        applied: Option<TactileRecord>,
        tissue: Option<TissueRecord>,
        pivot: Option<PivotRecord>,
        joints: Option<JointsRecord>,
        bench: Option<Box<dyn ArrayBench>>,
    ) -> Self {
        Self {
            settings,
            applied,
            tissue,
            pivot,
            joints,
            tare: None,
            recording: None,
            bench,
        }
    }

    /// The tissue frame a calibration placed, if any.
    pub fn tissue_record(&self) -> Option<&TissueRecord> {
        self.tissue.as_ref()
    }

    /// The encoder zero offset in use (zero without a joints calibration), rad.
    pub fn joint_zero(&self) -> [f64; 3] {
        self.joints.as_ref().map_or([0.0; 3], |r| r.zero_offset_rad)
    }

    /// The pivot a calibration found, if any.
    pub fn pivot_record(&self) -> Option<&PivotRecord> {
        self.pivot.as_ref()
    }

    pub fn recording(&self) -> bool {
        self.recording.is_some()
    }

    /// The tactile calibration trackers are fed through, if any.
    pub fn tactile(&self) -> Option<&TactileCalibration> {
        self.applied.as_ref().map(|r| &r.calibration)
    }

    /// The array geometry a new tracker is built with.
    pub fn sensor(&self) -> ArrayGeometry {
        self.tactile()
            .and_then(|c| c.geometry(&self.settings.sensor).ok())
            .unwrap_or(self.settings.sensor)
    }

    /// For `status` and the trial's metadata; `tissue_stale`: why the tissue frame is no
    /// longer true, if it is not (`tissue_stale.rs`).
    pub fn describe(&self, tissue_stale: Option<&str>) -> Value {
        json!({
            "file": self.settings.file,
            "tactile": self.applied.as_ref().map(|r| json!({
                "measured_utc": r.measured_utc,
                "unusable_elements": Vec::<usize>::from(r.calibration.unusable_mask()),
                "noise_sd_n": r.calibration.noise_sd_n(),
            })),
            "tissue": self.tissue.as_ref().map(|r| json!({
                "measured_utc": r.measured_utc,
                "placement": r.placement,
                "rms_residual_m": r.rms_residual_m,
                "tilt_rad": r.tilt_rad,
                "stale": tissue_stale,
            })),
            "pivot": self.pivot.as_ref().map(|r| json!({
                "measured_utc": r.measured_utc,
                "pivot_in_base_m": r.pivot_in_base_m,
                "offset_m": r.offset_m,
                "rms_residual_m": r.rms_residual_m,
            })),
            "joints": self.joints.as_ref().map(|r| json!({
                "measured_utc": r.measured_utc,
                "zero_offset_rad": r.zero_offset_rad,
                "stops": r.stops,
                "stops_measured_utc": r.stops_measured_utc,
                "stop_checks": r.stop_checks,
                "stops_inside_limits": super::joints_sweep::inside_limits(&r.stops),
            })),
            "tare_pending": self.tare.is_some(),
            "recording": self.recording.as_ref().map(|r| json!({
                "step": r.step.step(), "frames": r.frames.len(), "of": r.wanted,
            })),
        })
    }
}

/// `c` with the numbers of its unusable elements made finite (JSON has no NaN; they are
/// never read).
pub fn json_safe(c: &TactileCalibration) -> TactileCalibration {
    let mut c = *c;
    for el in c.elements.iter_mut().filter(|el| !el.status.is_usable()) {
        for v in [
            &mut el.offset_n,
            &mut el.noise_sd_n,
            &mut el.gain,
            &mut el.gain_standard_error,
        ] {
            if !v.is_finite() {
                *v = 0.0;
            }
        }
    }
    c
}

fn element_json(c: &TactileCalibration) -> Value {
    Value::Array(
        c.elements
            .iter()
            .enumerate()
            .map(|(e, el)| {
                json!({
                    "element": e,
                    "offset_n": el.offset_n,
                    "noise_sd_n": el.noise_sd_n,
                    "gain": el.gain,
                    "gain_standard_error": el.gain_standard_error,
                    "status": format!("{:?}", el.status).to_lowercase(),
                })
            })
            .collect(),
    )
}

impl Supervisor {
    /// `calibrate`: start a recording, or say why not.
    pub(super) fn calibrate(&mut self, id: u64, to: Responder, step: CalibrateStep) {
        if let CalibrateStep::TissueTouch {
            points,
            course,
            course_lateral_m,
        } = step
        {
            return self.tissue_start(id, to, points, course.map(|c| (c, course_lateral_m)));
        }
        if let CalibrateStep::PivotTouch { points } = step {
            return self.pivot_start(id, to, points);
        }
        if let CalibrateStep::JointsHome { .. } = step {
            return self.joints_home(id, to);
        }
        if let CalibrateStep::JointsSweep { joints, .. } = step {
            return self.joints_sweep(id, to, &joints);
        }
        let cal = &mut self.calibration;
        if cal.recording.is_some() {
            return self.reply_err(
                id,
                to,
                ErrorCode::WrongState,
                "a calibration recording is under way; wait for it or stop it",
            );
        }
        if matches!(step, CalibrateStep::TactileLoad { .. }) && cal.tare.is_none() {
            return self.reply_err(
                id,
                to,
                ErrorCode::Refused,
                "the loaded recording needs a tare first: `calibrate tactile tare` with nothing on the array",
            );
        }
        let duration_s = step
            .duration_s()
            .unwrap_or(cal.settings.tactile_recording_s);
        let rate = cal.settings.sensor.sample_rate_hz;
        let wanted = ((duration_s * rate).ceil() as usize).max(cal.settings.tactile.min_frames);
        let wall = Duration::from_secs_f64(duration_s / cal.settings.time_scale.max(1e-3));
        cal.recording = Some(Recording {
            step: step.clone(),
            frames: Vec::with_capacity(wanted),
            wanted,
            deadline: Instant::now() + wall + FRAME_GRACE,
        });
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": step.procedure(),
            "step": step.step(), "phase": "started", "frames": wanted});
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::INFO,
            format!(
                "calibrating the tactile array: recording {wanted} frames {}",
                match step {
                    CalibrateStep::TactileTare { .. } => "with nothing on it".to_string(),
                    CalibrateStep::TactileLoad {
                        load_per_element_n, ..
                    } => format!("under {load_per_element_n} N per element"),
                    CalibrateStep::TissueTouch { .. }
                    | CalibrateStep::PivotTouch { .. }
                    | CalibrateStep::JointsHome { .. }
                    | CalibrateStep::JointsSweep { .. } => {
                        String::new()
                    }
                }
            ),
        );
        self.reply_ok(
            id,
            to,
            json!({"procedure": step.procedure(), "step": step.step(), "frames": wanted,
                "duration_s": duration_s}),
            false,
        );
    }

    /// The simulator's hand: the array to the bench or back.
    pub(super) fn place_array(&mut self, id: u64, to: Responder, load: Option<f64>) {
        let placed = self.calibration.bench.as_ref().map(|b| b.place(load));
        match placed {
            Some(true) => self.reply_ok(
                id,
                to,
                json!({"on": if load.is_some() { "bench" } else { "tissue" },
                    "load_per_element_n": load}),
                false,
            ),
            Some(false) => self.reply_err(id, to, ErrorCode::Unavailable, "the simulator is gone"),
            None => self.reply_err(
                id,
                to,
                ErrorCode::Refused,
                "only the simulator can move the array to the bench; on a rig, do it by hand",
            ),
        }
    }

    /// Every raw frame, before anything corrects it.
    pub(super) fn calibration_frame(&mut self, frame: &TactileFrame) {
        let Some(r) = self.calibration.recording.as_mut() else {
            return;
        };
        r.frames.push(*frame);
        if r.frames.len() >= r.wanted {
            self.finish_recording();
        }
    }

    /// A recording that stopped getting frames fails.
    pub(super) fn calibration_tick(&mut self) {
        let late = self
            .calibration
            .recording
            .as_ref()
            .is_some_and(|r| Instant::now() > r.deadline);
        if let Some(r) = late.then(|| self.calibration.recording.take()).flatten() {
            let why = format!(
                "the array sent {} of {} frames in the time the recording had; is it streaming? (nothing was changed)",
                r.frames.len(),
                r.wanted
            );
            self.calibration_failed(r.step, &why);
        }
    }

    /// `stop` ends a recording without a result.
    pub(super) fn calibration_stop(&mut self) {
        if let Some(r) = self.calibration.recording.take() {
            self.calibration_failed(r.step, "stopped (nothing was changed)");
        }
    }

    fn calibration_failed(&mut self, step: CalibrateStep, why: &str) {
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": step.procedure(),
            "step": step.step(), "phase": "failed", "reason": why});
        self.publish(Stream::Calibration, 0, &ev, false);
        self.log_line(
            t,
            level::WARNING,
            format!("tactile calibration {}: {why}", step.step()),
        );
    }

    fn finish_recording(&mut self) {
        let Some(r) = self.calibration.recording.take() else {
            return;
        };
        let settings = self.calibration.settings.tactile;
        match r.step {
            CalibrateStep::TactileTare { .. } => match Tare::from_frames(&r.frames, &settings) {
                Ok(tare) => {
                    let t = self.now_s();
                    let ev = json!({"event": "calibration", "t_s": t, "procedure": "tactile",
                        "step": "tare", "phase": "done", "frames": tare.frames(),
                        "offset_n": tare.offset_n(), "noise_sd_n": tare.noise_sd_n()});
                    self.calibration.tare = Some(tare);
                    self.publish(Stream::Calibration, 0, &ev, false);
                    self.log_line(
                        t,
                        level::INFO,
                        "tactile tare recorded; now put the known load on the array".into(),
                    );
                }
                Err(e) => self.calibration_failed(r.step, &e.to_string()),
            },
            CalibrateStep::TactileLoad {
                load_per_element_n, ..
            } => self.finish_tactile(r.step, &r.frames, load_per_element_n),
            CalibrateStep::TissueTouch { .. }
            | CalibrateStep::PivotTouch { .. }
            | CalibrateStep::JointsHome { .. }
            | CalibrateStep::JointsSweep { .. } => {}
        }
    }

    fn finish_tactile(&mut self, step: CalibrateStep, frames: &[TactileFrame], load: f64) {
        let Some(tare) = self.calibration.tare else {
            return self.calibration_failed(step, "no tare");
        };
        let cal = match control::calibration::calibrate_gains(&tare, frames, load) {
            Ok(c) => c,
            Err(e) => return self.calibration_failed(step, &e.to_string()),
        };
        let checks = cal.checks(&self.calibration.settings.tolerances);
        let record = TactileRecord {
            measured_utc: utc_stamp(std::time::SystemTime::now()),
            no_load_frames: tare.frames(),
            loaded_frames: frames.len(),
            calibration: cal,
            checks: checks.iter().map(CheckRecord::from).collect(),
            passed: all_passed(&checks),
        };
        // Written only if it passed and leaves enough elements with the configured ones
        // skipped too; applied only once written.
        let saved = usable_record(&record, &self.calibration.settings.sensor)
            .map_err(|e| format!("{e}: not written, the calibration in use is unchanged"))
            .and_then(|_| self.save_tactile(&record));
        let applied = saved.is_ok();
        if applied {
            self.calibration.applied = Some(record.clone());
            self.calibration.tare = None;
        }
        let t = self.now_s();
        let ev = json!({"event": "calibration", "t_s": t, "procedure": "tactile",
            "step": "load", "phase": "done", "passed": record.passed,
            "applied": applied,
            "file": applied.then(|| self.calibration.settings.file.clone()),
            "reason": saved.as_ref().err(),
            "checks": record.checks, "elements": element_json(&json_safe(&cal)),
            "unusable_elements": Vec::<usize>::from(cal.unusable_mask()),
            "noise_sd_n": cal.noise_sd_n(),
            "load_per_element_n": load});
        // To the live view's /events (no trial is open to record it in).
        self.record(Topic::Events, t, &ev);
        self.publish(Stream::Calibration, 0, &ev, false);
        let line = match &saved {
            Ok(()) => format!(
                "tactile calibration passed, written to {} and in use (unusable elements {:?})",
                self.calibration.settings.file.display(),
                Vec::<usize>::from(cal.unusable_mask())
            ),
            Err(e) => format!("tactile calibration not applied: {e}"),
        };
        self.log_line(t, if applied { level::INFO } else { level::WARNING }, line);
    }

    /// Write `record` into the calibration file (keeping what else it holds).
    fn save_tactile(&self, record: &TactileRecord) -> Result<(), String> {
        self.save_calibration("the calibration in use", |f| {
            f.tactile = Some(record.clone())
        })
    }

    /// Rewrite the calibration file with `put`'s change, keeping what else it holds; on
    /// failure the error says that `in_use` is unchanged.
    pub(super) fn save_calibration(
        &self,
        in_use: &str,
        put: impl FnOnce(&mut CalibrationFile),
    ) -> Result<(), String> {
        let path = &self.calibration.settings.file;
        let mut file = match calibration_file::load(path) {
            Ok(Some(l)) => l.value,
            Ok(None) => CalibrationFile::default(),
            // The file the daemon started with became unreadable: do not overwrite what a
            // person may want to look at.
            Err(e) => return Err(format!("not written: the file there cannot be read: {e}")),
        };
        put(&mut file);
        calibration_file::save(path, &file)
            .map_err(|e| format!("not applied: {e} ({in_use} is unchanged)"))
    }
}
