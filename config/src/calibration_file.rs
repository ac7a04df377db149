//! The rig's calibration file: what the calibration procedures measured, with each result's
//! checks against the tolerances and whether it passed. The daemon loads it beside its
//! config at start and applies the results that passed; a procedure that passes rewrites it
//! (atomically: a crash leaves the old file or the new one, never half of one).

use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::load::{ConfigError, Loaded, load_file};
use crate::validate::{Validate, Validator};
use control::calibration::{Bound, Check, TactileCalibration};
use control::frames::TissuePlacement;

/// Bumped on any incompatible change to the file.
pub const CALIBRATION_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    pub version: u32,
    /// The tactile array's tare, gains and unusable elements; absent: not calibrated.
    #[serde(default)]
    pub tactile: Option<TactileRecord>,
    /// The tissue frame from touched points; absent: `robot.tissue` as configured.
    #[serde(default)]
    pub tissue: Option<TissueRecord>,
    /// The pivot (incision) from touches on a level plate; absent: `robot.pivot` as
    /// configured (files written before the pivot procedure have none).
    #[serde(default)]
    pub pivot: Option<PivotRecord>,
    /// The joints' encoder zero and stops from the homing and the sweep; absent: the
    /// encoders as the backend reads them (files written before the joints procedure have
    /// none).
    #[serde(default)]
    pub joints: Option<JointsRecord>,
}

impl Default for CalibrationFile {
    fn default() -> Self {
        Self {
            version: CALIBRATION_VERSION,
            tactile: None,
            tissue: None,
            pivot: None,
            joints: None,
        }
    }
}

/// One joints calibration as measured: the homing's zero offsets and the stops the sweep
/// found, with their checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointsRecord {
    /// When the sweep ended, UTC.
    pub measured_utc: String,
    /// The reset pose's known angles (`calibration.joints.reset_pose_rad`), rad.
    pub reset_pose_rad: [f64; 3],
    /// What the encoders read there, before this record's offset, rad.
    pub read_rad: [f64; 3],
    /// What the daemon adds to every encoder angle once this record is in use
    /// (`reset_pose_rad − read_rad`), rad.
    pub zero_offset_rad: [f64; 3],
    /// Each stop the sweep looked for, in the order swept (empty until a sweep ran; a new
    /// homing clears them, as they were read through the old zero).
    pub stops: Vec<StopRecord>,
    /// The homing's checks.
    pub checks: Vec<CheckRecord>,
    /// Every homing check passed; the daemon applies only a record that passed.
    pub passed: bool,
    /// When the stop sweep ended, UTC (absent: no sweep yet; files written before the sweep
    /// have none).
    #[serde(default)]
    pub stops_measured_utc: Option<String>,
    /// Each stop's margin against `calibration.joints.min_stop_margin_rad`. A stop that fails
    /// it is reported, not hidden, and does not stop the zero being used: the software limits
    /// stay the config's (docs/rig-bring-up.md section 1).
    #[serde(default)]
    pub stop_checks: Vec<CheckRecord>,
}

/// Where the sweep found one stop, against the software limit on that side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StopRecord {
    pub joint: usize,
    /// `lower` or `upper`.
    pub side: control::calibration::Side,
    /// The joint's angle where it stalled (or where the overtravel ended), corrected by
    /// the record's zero offset, rad.
    pub at_rad: f64,
    /// True: a stall against the torque cap; false: the overtravel ended first.
    pub stalled: bool,
    /// `robot.joint_limits` on that side, rad.
    pub software_limit_rad: f64,
    /// How far the stop lies beyond the software limit (negative: inside it), rad.
    pub margin_rad: f64,
}

/// One tissue-frame calibration as measured: the touched points, the fit and its checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TissueRecord {
    /// When the last touch ended, UTC.
    pub measured_utc: String,
    /// The touched surface points, robot base frame, m.
    pub surface_in_base_m: Vec<[f64; 3]>,
    /// The two touched points along the artery's course (tissue `+x` from the first toward
    /// the second), base frame, m; absent: the yaw was kept from the config.
    #[serde(default)]
    pub course_in_base_m: Option<[[f64; 3]; 2]>,
    /// Tissue `z` of the course's line, m (0: the artery along tissue `x`).
    #[serde(default)]
    pub course_lateral_m: f64,
    /// The placement the touches were made in (the config's, or an earlier calibration's).
    pub prior: TissuePlacement,
    /// The fitted placement: what the kinematics use once it passed.
    pub placement: TissuePlacement,
    /// The fitted surface's tilt from level, rad.
    pub tilt_rad: f64,
    /// The pivot the touches were placed through, base frame, m, and the encoder zero
    /// offsets they were read with, rad: a later pivot calibration or homing moves every
    /// touched point, and the frame must then be measured again. Absent in files from
    /// before 2026-11-28.
    #[serde(default)]
    pub pivot_in_base_m: Option<[f64; 3]>,
    #[serde(default)]
    pub joint_zero_rad: Option<[f64; 3]>,
    /// RMS and largest distance of the touched points from the fitted plane, m.
    pub rms_residual_m: f64,
    pub max_residual_m: f64,
    pub checks: Vec<CheckRecord>,
    /// Every check passed; the daemon applies only a record that passed.
    pub passed: bool,
}

/// One pivot calibration as measured: the touches of a level plate, the fit and its checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PivotRecord {
    /// When the last touch ended, UTC.
    pub measured_utc: String,
    /// The touched points (sensor centre where the surface was met), tissue frame as the
    /// kinematics believed them through `prior_pivot_in_base_m` and `placement`, m.
    pub touched_in_tissue_m: Vec<[f64; 3]>,
    /// The tissue frame the touches were read in.
    pub placement: TissuePlacement,
    /// The pivot the touches were made through (the config's, or an earlier calibration's),
    /// base frame, m.
    pub prior_pivot_in_base_m: [f64; 3],
    /// The fitted pivot: what the kinematics use once it passed, base frame, m.
    pub pivot_in_base_m: [f64; 3],
    /// Its base `x` and `z` offset from the prior, and the standard error of each, m.
    pub offset_m: [f64; 2],
    pub standard_error_m: [f64; 2],
    /// The level plate's height, base frame, m.
    pub plate_height_m: f64,
    /// RMS and largest height residual of the touches about the level plate, m.
    pub rms_residual_m: f64,
    pub max_residual_m: f64,
    pub checks: Vec<CheckRecord>,
    /// Every check passed; the daemon applies only a record that passed.
    pub passed: bool,
}

/// One tactile calibration as measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TactileRecord {
    /// When the loaded recording ended, UTC (`2026-11-28T01-02-03Z`).
    pub measured_utc: String,
    /// Frames in the no-load and the loaded recordings.
    pub no_load_frames: usize,
    pub loaded_frames: usize,
    pub calibration: TactileCalibration,
    pub checks: Vec<CheckRecord>,
    /// Every check passed; the daemon applies only a record that passed.
    pub passed: bool,
}

/// A check as written to the file (`control::calibration::Check` with owned names).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckRecord {
    pub quantity: String,
    pub value: f64,
    /// `at_most` or `at_least`.
    pub bound: String,
    pub limit: f64,
    pub unit: String,
    pub passed: bool,
}

impl From<&Check> for CheckRecord {
    fn from(c: &Check) -> Self {
        Self {
            quantity: c.quantity.to_string(),
            value: c.value,
            bound: match c.bound {
                Bound::AtMost => "at_most",
                Bound::AtLeast => "at_least",
            }
            .to_string(),
            limit: c.limit,
            unit: c.unit.to_string(),
            passed: c.passed(),
        }
    }
}

impl Validate for CalibrationFile {
    fn validate(&self, v: &mut Validator) {
        v.check(
            self.version == CALIBRATION_VERSION,
            "version",
            format!(
                "calibration file version {} is not supported (this build reads {CALIBRATION_VERSION})",
                self.version
            ),
        );
        if let Some(t) = &self.tactile {
            v.at("tactile", |v| {
                v.check(!t.measured_utc.is_empty(), "measured_utc", "must say when");
                if let Err(e) = t.calibration.validate() {
                    v.problem("calibration", e);
                }
                v.check(
                    !t.passed || t.checks.iter().all(|c| c.passed),
                    "passed",
                    "is true, but a check failed",
                );
            });
        }
        if let Some(t) = &self.tissue {
            v.at("tissue", |v| {
                v.check(!t.measured_utc.is_empty(), "measured_utc", "must say when");
                let p = &t.placement;
                v.check(
                    p.origin_in_base_m.iter().all(|x| x.is_finite()) && p.yaw_rad.is_finite(),
                    "placement",
                    "must be finite",
                );
                v.check(
                    t.surface_in_base_m.len() >= 3,
                    "surface_in_base_m",
                    "needs at least 3 touched points",
                );
                v.check(
                    t.pivot_in_base_m
                        .is_none_or(|p| p.iter().all(|x| x.is_finite())),
                    "pivot_in_base_m",
                    "must be finite",
                );
                v.check(
                    t.joint_zero_rad
                        .is_none_or(|z| z.iter().all(|x| x.is_finite())),
                    "joint_zero_rad",
                    "must be finite",
                );
                v.check(
                    !t.passed || t.checks.iter().all(|c| c.passed),
                    "passed",
                    "is true, but a check failed",
                );
            });
        }
        if let Some(j) = &self.joints {
            v.at("joints", |v| validate_joints(j, v));
        }
        if let Some(p) = &self.pivot {
            v.at("pivot", |v| {
                v.check(!p.measured_utc.is_empty(), "measured_utc", "must say when");
                v.check(
                    p.pivot_in_base_m.iter().all(|x| x.is_finite()),
                    "pivot_in_base_m",
                    "must be finite",
                );
                v.check(
                    p.touched_in_tissue_m.len() >= control::calibration::level_pivot::MIN_TOUCHES,
                    "touched_in_tissue_m",
                    format!(
                        "needs at least {} touched points",
                        control::calibration::level_pivot::MIN_TOUCHES
                    ),
                );
                v.check(
                    !p.passed || p.checks.iter().all(|c| c.passed),
                    "passed",
                    "is true, but a check failed",
                );
            });
        }
    }
}

fn validate_joints(j: &JointsRecord, v: &mut Validator) {
    v.check(!j.measured_utc.is_empty(), "measured_utc", "must say when");
    for (name, values) in [
        ("reset_pose_rad", &j.reset_pose_rad),
        ("read_rad", &j.read_rad),
        ("zero_offset_rad", &j.zero_offset_rad),
    ] {
        v.check(values.iter().all(|x| x.is_finite()), name, "must be finite");
    }
    for (i, s) in j.stops.iter().enumerate() {
        v.check(
            s.joint < 3,
            &format!("stops[{i}].joint"),
            format!("there is no joint {} (joints 0, 1 and 2)", s.joint),
        );
        v.check(
            s.at_rad.is_finite() && s.software_limit_rad.is_finite() && s.margin_rad.is_finite(),
            &format!("stops[{i}]"),
            "must be finite",
        );
    }
    v.check(
        !j.passed || j.checks.iter().all(|c| c.passed),
        "passed",
        "is true, but a check failed",
    );
}

/// The calibration file at `path`: `Ok(None)` if there is none yet; an error naming the
/// file, line and field if it cannot be used.
pub fn load(path: &Path) -> Result<Option<Loaded<CalibrationFile>>, ConfigError> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        _ => load_file(path).map(Some),
    }
}

/// Write `file` to `path` so that the file on disk is the old one or the new one whole,
/// even across a crash or a power cut: a temporary file in the same folder, synced, renamed
/// over the old one, and the folder synced. The folder is made if missing. Nothing is
/// changed if any step fails.
pub fn save(path: &Path, file: &CalibrationFile) -> Result<(), String> {
    let text = ron::ser::to_string_pretty(file, ron::ser::PrettyConfig::default())
        .map_err(|e| format!("cannot write the calibration as RON: {e}"))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .ok_or_else(|| format!("{} names no file", path.display()))?;
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot make {}: {e}", dir.display()))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(
            b"// pulsetrack rig calibration, written by the daemon (docs/rig-bring-up.md)\n",
        )?;
        f.write_all(text.as_bytes())?;
        f.write_all(b"\n")?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)?;
        std::fs::File::open(dir)?.sync_all()
    })();
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("cannot write {}: {e}", path.display())
    })
}

#[cfg(test)]
#[path = "calibration_file_tests.rs"]
mod tests;
