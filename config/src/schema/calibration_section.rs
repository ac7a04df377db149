//! The `calibration` section: where the rig's calibration file lives and the tolerances its
//! results are judged by (docs/calibration.md, "Rig calibration").

use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};
use control::calibration::{JointSettings, TactileSettings, Tolerances, TouchSettings};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CalibrationSection {
    /// The calibration file the daemon loads at start and writes when a procedure passes.
    /// `{state}` is the daemon's state directory (the shipped unit cannot write /etc, where
    /// its config lives); a relative path resolves against the config file's folder.
    pub file: String,
    /// Pass/fail limits of each procedure's result.
    pub tolerances: Tolerances,
    /// Thresholds of the tactile array's element checks.
    pub tactile: TactileSettings,
    /// Seconds of frames each tactile recording (no load, known load) takes by default.
    pub tactile_recording_s: f64,
    /// The tissue-frame procedure's touches: thresholds, clearance and speeds.
    pub tissue: TouchSettings,
    /// The joints' homing and stop sweep: the reset pose, the sweep's speed and torque cap,
    /// and its pass limits.
    pub joints: JointSettings,
}

impl Default for CalibrationSection {
    fn default() -> Self {
        Self {
            file: "{state}/calibration.ron".to_string(),
            tolerances: Tolerances::default(),
            tactile: TactileSettings::default(),
            tactile_recording_s: 5.0,
            tissue: TouchSettings::default(),
            joints: JointSettings::default(),
        }
    }
}

impl Validate for CalibrationSection {
    fn validate(&self, v: &mut Validator) {
        v.check(!self.file.is_empty(), "file", "must name a file");
        if let Err(e) = self.tolerances.check() {
            v.problem("tolerances", e);
        }
        if let Err(e) = self.tactile.check() {
            v.problem("tactile", e);
        }
        v.in_range("tactile_recording_s", self.tactile_recording_s, 0.1, 600.0);
        if let Err(e) = self.tissue.check() {
            v.problem("tissue", e);
        }
        if let Err(e) = self.joints.check() {
            v.problem("joints", e);
        }
    }
}
