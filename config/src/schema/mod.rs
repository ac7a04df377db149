//! The daemon's configuration file: `Config(version: 1, backend: ..., ...)`.
//!
//! Sections other than `backend` are optional; an absent section takes its documented
//! defaults. Types that the control core consumes directly (geometry, gains, tracker
//! constants) are defined in `control` and validated here.

mod backend;
mod calibration_section;
mod control_section;
mod daemon_sections;
mod instrument;
mod live_section;
mod robot;
mod tracker_section;

use serde::{Deserialize, Serialize};

pub use backend::{
    Backend, CanAdapter, CanJoints, HardwareBackend, SLCAN_BITRATES, SerialTactile, SimBackend,
};
pub use calibration_section::CalibrationSection;
pub use control_section::ControlSection;
pub use daemon_sections::{
    ConsoleSection, OperationSection, RealtimeSection, RecordingSection, SafetySection,
};
pub use live_section::{DEFAULT_LIVE_PORT, LiveSection};
pub use robot::RobotSection;
pub use tracker_section::TrackerSection;

use crate::validate::{Validate, Validator};

/// The file format version this build reads.
pub const CONFIG_VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Config", deny_unknown_fields)]
pub struct Config {
    pub version: u32,
    pub backend: Backend,
    #[serde(default)]
    pub robot: RobotSection,
    #[serde(default)]
    pub control: ControlSection,
    #[serde(default)]
    pub sensor: control::sensor::ArrayGeometry,
    #[serde(default)]
    pub tracker: TrackerSection,
    #[serde(default)]
    pub safety: SafetySection,
    #[serde(default)]
    pub operation: OperationSection,
    #[serde(default)]
    pub realtime: RealtimeSection,
    #[serde(default)]
    pub console: ConsoleSection,
    #[serde(default)]
    pub recording: RecordingSection,
    /// The live view (Foxglove WebSocket); absent: off.
    #[serde(default)]
    pub live: LiveSection,
    /// The rig's calibration file and the tolerances its procedures are judged by.
    #[serde(default)]
    pub calibration: CalibrationSection,
    /// The autonomous search of a named region (issue 17; docs/search.md).
    #[serde(default)]
    pub search: control::search::SearchParams,
    /// What the gimbal carries; absent: only the arm's own bodies are gravity-compensated.
    #[serde(default)]
    pub instrument: Option<control::pd::gravity::Instrument>,
    /// The instrument's shaft as far as its bending and weight go: with it the daemon reads
    /// where the sensor is from the arm's torques (docs/kinematics.md, "The rod's
    /// deflection") and `beatslide` checks its points against that reading; absent: no
    /// reading.
    #[serde(default)]
    pub rod: Option<control::kinematics::RodMechanics>,
}

impl Validate for Config {
    fn validate(&self, v: &mut Validator) {
        v.check(
            self.version == CONFIG_VERSION,
            "version",
            format!(
                "unsupported version {} (this build reads {CONFIG_VERSION})",
                self.version
            ),
        );
        v.section("backend", &self.backend);
        v.section("robot", &self.robot);
        v.section("control", &self.control);
        v.section("sensor", &self.sensor);
        v.section("tracker", &self.tracker);
        v.at("tracker", |v| {
            self.tracker.validate_with_sensor(&self.sensor, v)
        });
        v.section("safety", &self.safety);
        v.section("operation", &self.operation);
        v.section("realtime", &self.realtime);
        v.section("console", &self.console);
        v.section("recording", &self.recording);
        v.section("live", &self.live);
        v.section("calibration", &self.calibration);
        if let Err(e) = self.search.validate() {
            v.at("search", |v| {
                v.check(false, e.field, format!("{} (got {})", e.why, e.value));
            });
        }
        if let Some(r) = &self.rod {
            v.at("rod", |v| {
                v.positive("bending_stiffness_nm2", r.bending_stiffness_nm2);
                v.positive("pivot_stiffness_n_per_m", r.pivot_stiffness_n_per_m);
                v.non_negative("rod_mass_kg", r.rod_mass_kg);
                v.non_negative("tip_mass_kg", r.tip_mass_kg);
                v.non_negative("tip_mass_height_m", r.tip_mass_height_m);
            });
        }
        if let Some(i) = &self.instrument {
            v.at("instrument", |v| {
                instrument::validate(i, &self.robot, &self.control, v);
            });
        }
    }
}

impl Validate for control::sensor::ArrayGeometry {
    fn validate(&self, v: &mut Validator) {
        v.positive("pitch_m", self.pitch_m);
        v.check(
            self.direction == 1.0 || self.direction == -1.0,
            "direction",
            format!("must be 1 or -1, got {}", self.direction),
        );
        v.positive("noise_sd_n", self.noise_sd_n);
        v.positive("sample_rate_hz", self.sample_rate_hz);
        let trusted = control::types::ELEMENTS - self.skip_elements.len();
        v.check(
            trusted >= control::sensor::MIN_TRUSTED_ELEMENTS,
            "skip_elements",
            format!(
                "leaves {trusted} elements; localization needs at least {}",
                control::sensor::MIN_TRUSTED_ELEMENTS
            ),
        );
    }
}

#[cfg(test)]
#[path = "sensor_tests.rs"]
mod sensor_tests;

#[cfg(test)]
#[path = "rod_tests.rs"]
mod rod_tests;

/// The shipped simulator config with one more top-level `section` (for tests of a section).
#[cfg(test)]
pub(crate) fn shipped_with(section: &str) -> String {
    let (_, text) = crate::shipped::SIM_CONFIG;
    let at = text
        .rfind(')')
        .expect("the shipped config ends with a parenthesis");
    format!("{}    {section}\n)", &text[..at])
}
