//! Which tracker runs, and every tracker's constants.

use control::sensor::ArrayGeometry;
use control::tracker::{BuildError, TRACKER_NAMES, TrackerParams, build};
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
        v.check(
            TRACKER_NAMES.contains(&self.name.as_str()),
            "name",
            format!(
                // Quoted and escaped: the name is the file's text, and a newline in it
                // would start an error line that names no file.
                "unknown tracker {:?}; known trackers: {}",
                self.name,
                TRACKER_NAMES.join(", ")
            ),
        );
        v.at("params", |v| {
            v.section("seed2002", &self.params.seed2002);
            v.section("beatslide", &self.params.beatslide);
        });
    }
}

impl TrackerSection {
    /// Checks that need the sensor as well (the band against the sample rate, windows in
    /// samples): the tracker must be buildable. Run only once the section alone is valid,
    /// so that a problem is not reported twice.
    pub fn validate_with_sensor(&self, sensor: &ArrayGeometry, v: &mut Validator) {
        let mut alone = Validator::new();
        self.validate(&mut alone);
        let mut sensor_alone = Validator::new();
        sensor.validate(&mut sensor_alone);
        if !alone.into_problems().is_empty() || !sensor_alone.into_problems().is_empty() {
            return;
        }
        match build(&self.name, &self.params, sensor) {
            Ok(_) => {}
            Err(BuildError::Unknown(e)) => v.problem("name", e.to_string()),
            Err(BuildError::Seed2002(e)) => v.problem(
                "params.seed2002",
                format!("{e} (with the sensor's {} Hz)", sensor.sample_rate_hz),
            ),
            Err(BuildError::BeatSlide(e)) => v.problem(
                "params.beatslide",
                format!("{e} (with the sensor's {} Hz)", sensor.sample_rate_hz),
            ),
        }
    }
}

/// Longest acquisition window accepted, s.
const MAX_WINDOW_S: f64 = 60.0;

impl Validate for control::tracker::seed2002::Seed2002Params {
    fn validate(&self, v: &mut Validator) {
        // Two complete pulses at the slowest period need more than a second.
        v.in_range("first_window_s", self.first_window_s, 1.0, MAX_WINDOW_S);
        v.in_range("window_s", self.window_s, 1.0, MAX_WINDOW_S);
        v.positive("band_low_hz", self.band_low_hz);
        v.positive("band_high_hz", self.band_high_hz);
        v.check(
            self.band_low_hz < self.band_high_hz,
            "band_high_hz",
            "must exceed band_low_hz",
        );
        v.check(
            (2..=1024).contains(&self.fir_order) && self.fir_order.is_multiple_of(2),
            "fir_order",
            format!(
                "must be even (a whole-sample group delay) and between 2 and 1024, got {}",
                self.fir_order
            ),
        );
        v.positive("min_period_s", self.min_period_s);
        v.positive("max_period_s", self.max_period_s);
        v.check(
            self.min_period_s < self.max_period_s,
            "max_period_s",
            "must exceed min_period_s",
        );
        if v.finite("threshold_fraction", self.threshold_fraction) {
            v.check(
                self.threshold_fraction > 0.0 && self.threshold_fraction < 1.0,
                "threshold_fraction",
                format!(
                    "must lie strictly between 0 and 1, got {}",
                    self.threshold_fraction
                ),
            );
        }
        v.check(
            (1..=1000).contains(&self.samples_per_mean),
            "samples_per_mean",
            format!("must be 1 to 1000, got {}", self.samples_per_mean),
        );
        v.positive("sigma_factor", self.sigma_factor);
        v.check(
            (2..=1000).contains(&self.regression_points),
            "regression_points",
            format!("must be 2 to 1000, got {}", self.regression_points),
        );
        v.in_range("step_growth", self.step_growth, 1.0, 10.0);
        v.in_range("backtrack_factor", self.backtrack_factor, 0.01, 0.99);
        v.check(
            (1..=1000).contains(&self.max_acquisitions),
            "max_acquisitions",
            format!("must be 1 to 1000, got {}", self.max_acquisitions),
        );
        v.positive("min_step_m", self.min_step_m);
        if let Some(s) = self.initial_step_m {
            v.positive("initial_step_m", s);
            v.check(
                s >= self.min_step_m,
                "initial_step_m",
                "must be at least min_step_m",
            );
        }
        if let Some(s) = self.max_step_m {
            v.positive("max_step_m", s);
            v.check(s > self.min_step_m, "max_step_m", "must exceed min_step_m");
        }
        v.positive("move_speed_m_s", self.move_speed_m_s);
    }
}

impl Validate for control::tracker::beatslide::BeatSlideParams {
    fn validate(&self, v: &mut Validator) {
        v.positive("min_period_s", self.min_period_s);
        v.positive("max_period_s", self.max_period_s);
        v.check(
            self.min_period_s < self.max_period_s,
            "max_period_s",
            "must exceed min_period_s",
        );
        // Noise alone reaches about 6 (docs/tracker-beatslide.md): lower is a false alarm
        // every few windows.
        v.in_range("detection_threshold", self.detection_threshold, 4.0, 1.0e4);
        v.in_range("coherent_s", self.coherent_s, 1.0, MAX_WINDOW_S);
        v.in_range("mark_window_s", self.mark_window_s, 1.0, MAX_WINDOW_S);
        v.in_range("mark_extend_s", self.mark_extend_s, 0.1, MAX_WINDOW_S);
        v.in_range(
            "mark_max_window_s",
            self.mark_max_window_s,
            1.0,
            MAX_WINDOW_S,
        );
        v.check(
            self.mark_max_window_s >= self.mark_window_s,
            "mark_max_window_s",
            "must be at least mark_window_s",
        );
        v.in_range("search_window_s", self.search_window_s, 1.0, MAX_WINDOW_S);
        v.in_range("fix_snr", self.fix_snr, 1.0, 1000.0);
        v.in_range("target_snr", self.target_snr, 1.0, 1000.0);
        v.check(
            (1..=64).contains(&self.max_beats_per_fix),
            "max_beats_per_fix",
            format!("must be 1 to 64, got {}", self.max_beats_per_fix),
        );
        v.in_range("max_speed_m_s", self.max_speed_m_s, 1e-4, 0.1);
        v.in_range(
            "max_travel_per_fix_m",
            self.max_travel_per_fix_m,
            0.001,
            0.1,
        );
        v.in_range("prediction_sd_m", self.prediction_sd_m, 1e-4, 0.01);
        v.in_range("max_blind_m", self.max_blind_m, 0.002, 0.2);
        v.check(
            (1..=100).contains(&self.sliding_misses),
            "sliding_misses",
            format!("must be 1 to 100, got {}", self.sliding_misses),
        );
        v.check(
            self.max_returns <= 100,
            "max_returns",
            format!("must be at most 100, got {}", self.max_returns),
        );
        v.in_range("gate_sigma", self.gate_sigma, 1.0, 100.0);
        v.in_range("gate_min_m", self.gate_min_m, 1e-4, 0.05);
        v.positive("curvature_prior_per_m", self.curvature_prior_per_m);
        v.positive("curvature_walk", self.curvature_walk);
        v.in_range("fix_floor_m", self.fix_floor_m, 1e-6, 0.01);
        v.in_range("tilt_deflection", self.tilt_deflection, 0.0, 0.2);
        v.in_range("return_speed_m_s", self.return_speed_m_s, 1e-4, 0.1);
        // The shipped threshold table reaches 600 s and holds these false-alarm rates.
        v.in_range("weak_limit_s", self.weak_limit_s, 0.0, 600.0);
        v.check(
            control::signal::weak_pulse::TABLE_PFAS.contains(&self.weak_false_alarm),
            "weak_false_alarm",
            format!(
                "must be 0.01 or 0.05 (the shipped threshold table's), got {}",
                self.weak_false_alarm
            ),
        );
        // Within the array's ±9 mm reach of the last fix.
        v.in_range("weak_step_m", self.weak_step_m, 0.001, 0.015);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use control::tracker::seed2002::Seed2002Params;

    fn problems(section: &TrackerSection, sensor: &ArrayGeometry) -> Vec<String> {
        let mut v = Validator::new();
        section.validate(&mut v);
        section.validate_with_sensor(sensor, &mut v);
        v.into_problems()
            .into_iter()
            .map(|p| format!("{}: {}", p.field, p.message))
            .collect()
    }

    #[test]
    fn the_defaults_are_valid_and_buildable() {
        assert_eq!(
            problems(&TrackerSection::default(), &ArrayGeometry::default()),
            Vec::<String>::new()
        );
    }

    #[test]
    fn names_the_field_of_each_problem() {
        let sensor = ArrayGeometry::default();
        let section = TrackerSection {
            name: "seed2003".into(),
            ..TrackerSection::default()
        };
        let p = problems(&section, &sensor);
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(
            p[0].starts_with("name: unknown tracker \"seed2003\"") && p[0].contains("seed2002")
        );

        let mut section = TrackerSection::default();
        section.params.seed2002 = Seed2002Params {
            fir_order: 63,
            threshold_fraction: 1.0,
            min_period_s: 2.0,
            max_period_s: 1.0,
            initial_step_m: Some(0.001),
            window_s: f64::NAN,
            ..Seed2002Params::default()
        };
        let p = problems(&section, &sensor);
        for field in [
            "params.seed2002.fir_order",
            "params.seed2002.threshold_fraction",
            "params.seed2002.max_period_s",
            "params.seed2002.initial_step_m",
            "params.seed2002.window_s",
        ] {
            assert!(p.iter().any(|m| m.starts_with(field)), "{field} in {p:?}");
        }
    }

    #[test]
    fn checks_the_band_against_the_sensor() {
        let slow = ArrayGeometry {
            sample_rate_hz: 3.0,
            ..ArrayGeometry::default()
        };
        let p = problems(&TrackerSection::default(), &slow);
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(
            p[0].starts_with("params.seed2002: ") && p[0].contains("3 Hz"),
            "{p:?}"
        );
    }

    /// Found with the `config_loader` fuzz target (docs/fuzzing.md; the minimized input):
    /// a tracker name with a newline broke the error into a line that named no file.
    #[test]
    fn every_error_line_names_the_file() {
        let text = "Config(version: 1, backend: Sim((scene: \"seed-arc-145.ron\")),\n  tracker: (name: \"seed37\n 54,\"))";
        let e = crate::load_str::<crate::Config>("c.ron", text).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(r#"unknown tracker "seed37\n 54,""#), "{msg}");
        for line in msg.lines() {
            assert!(line.starts_with("c.ron:2:"), "{line:?} in {msg:?}");
        }
    }
}
