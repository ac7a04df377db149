//! Which tracker runs, and every tracker's constants.

use control::tracker::TrackerParams;
use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackerSection {
    /// The tracker to run, by name (`seed2002`, ...).
    pub name: String,
    pub params: TrackerParams,
}

impl Default for TrackerSection {
    fn default() -> Self {
        Self {
            name: "seed2002".to_string(),
            params: TrackerParams::default(),
        }
    }
}

impl Validate for TrackerSection {
    fn validate(&self, v: &mut Validator) {
        v.check(!self.name.trim().is_empty(), "name", "must name a tracker");
        v.at("params", |v| v.section("seed2002", &self.params.seed2002));
    }
}

impl Validate for control::tracker::seed2002::Seed2002Params {
    fn validate(&self, v: &mut Validator) {
        v.positive("first_window_s", self.first_window_s);
        v.positive("window_s", self.window_s);
        v.positive("band_low_hz", self.band_low_hz);
        v.positive("band_high_hz", self.band_high_hz);
        v.check(
            self.band_low_hz < self.band_high_hz,
            "band_high_hz",
            "must exceed band_low_hz",
        );
        v.check(
            (2..=1024).contains(&self.fir_order),
            "fir_order",
            format!("must be between 2 and 1024, got {}", self.fir_order),
        );
        v.in_range("threshold_fraction", self.threshold_fraction, 0.0, 1.0);
        v.check(
            self.samples_per_mean >= 1,
            "samples_per_mean",
            "must be at least 1",
        );
        v.positive("sigma_factor", self.sigma_factor);
        v.check(
            self.regression_points >= 2,
            "regression_points",
            "must be at least 2",
        );
        v.in_range("step_growth", self.step_growth, 1.0, 10.0);
        v.in_range("backtrack_factor", self.backtrack_factor, 0.01, 0.99);
        v.check(
            self.max_acquisitions >= 1,
            "max_acquisitions",
            "must be at least 1",
        );
        if let Some(s) = self.initial_step_m {
            v.positive("initial_step_m", s);
        }
        v.positive("min_step_m", self.min_step_m);
        if let Some(s) = self.max_step_m {
            v.positive("max_step_m", s);
            v.check(s > self.min_step_m, "max_step_m", "must exceed min_step_m");
        }
        v.positive("move_speed_m_s", self.move_speed_m_s);
    }
}
