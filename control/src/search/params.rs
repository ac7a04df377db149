//! The search's constants, with the config's defaults and their checks.

use serde::{Deserialize, Serialize};

/// How a search explores and when it stops. SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SearchParams {
    /// Heart periods a pulse may have, s (0.8-1.8 Hz hearts and a margin).
    pub min_period_s: f64,
    pub max_period_s: f64,
    /// Pulse search threshold (the normalized largest eigenvalue; `beatslide`'s mark uses
    /// the same statistic at 8, whose false-alarm rate is measured in
    /// docs/tracker-beatslide.md).
    pub detection_threshold: f64,
    /// A look before any pulse has been felt, s: it must hold 2.5 of the longest periods.
    pub first_look_s: f64,
    /// A look once the heart's period is known: at least this many periods, and long
    /// enough for the strongest pulse felt so far to reach `look_snr` (its kernel fit's
    /// amplitude over its SE), up to `max_look_s`.
    pub look_periods: f64,
    pub look_snr: f64,
    pub max_look_s: f64,
    /// Time at rest after arriving before a look starts (the tissue's creep), s.
    pub settle_s: f64,
    /// Speed between looks, m/s.
    pub speed_m_s: f64,
    /// Largest heading of the artery from `+x`, rad: the array lies along `z` and follows
    /// only an artery that crosses it.
    pub max_heading_rad: f64,
    /// The map's grid.
    pub offset_step_m: f64,
    pub heading_step_rad: f64,
    /// Chance that a look feels an artery within its reach; of a false detection.
    pub p_detect: f64,
    pub p_false: f64,
    /// Added in quadrature to every felt place's SE, m.
    pub place_floor_m: f64,
    /// Prior probability that the region holds no artery.
    pub prior_absent: f64,
    /// Found: an artery is this probable, its heading lies within `heading_tolerance_rad`
    /// of the best line's with probability `heading_confidence`, and two felt points at
    /// least `seed_separation_m` apart agree with it.
    pub found_probability: f64,
    pub heading_tolerance_rad: f64,
    pub heading_confidence: f64,
    pub seed_separation_m: f64,
    /// Not found: no artery is this probable.
    pub absent_probability: f64,
    /// Give up after this long, s.
    pub max_time_s: f64,
    /// Candidate look spacing over the region, m.
    pub candidate_step_m: f64,
    /// Looks stay this far inside the region's edges, m: a compliant rod carries the sensor
    /// past the arm's target by a few millimetres.
    pub edge_margin_m: f64,
}

impl Default for SearchParams {
    fn default() -> Self {
        Self {
            min_period_s: 0.45,
            max_period_s: 1.6,
            detection_threshold: 8.0,
            first_look_s: 4.0,
            look_periods: 2.0,
            look_snr: 8.0,
            max_look_s: 10.0,
            settle_s: 0.3,
            speed_m_s: 0.015,
            max_heading_rad: 60f64.to_radians(),
            offset_step_m: 0.25e-3,
            heading_step_rad: 1f64.to_radians(),
            p_detect: 0.95,
            p_false: 0.002,
            place_floor_m: 0.3e-3,
            prior_absent: 0.5,
            found_probability: 0.99,
            heading_tolerance_rad: 5f64.to_radians(),
            heading_confidence: 0.95,
            seed_separation_m: 0.01,
            absent_probability: 0.95,
            max_time_s: 120.0,
            candidate_step_m: 0.002,
            edge_margin_m: 0.003,
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("search.{field} = {value}: {why}")]
pub struct ParamsError {
    pub field: &'static str,
    pub value: f64,
    pub why: &'static str,
}

impl SearchParams {
    pub fn validate(&self) -> Result<(), ParamsError> {
        let positive = [
            ("min_period_s", self.min_period_s),
            ("max_period_s", self.max_period_s),
            ("detection_threshold", self.detection_threshold),
            ("first_look_s", self.first_look_s),
            ("look_periods", self.look_periods),
            ("look_snr", self.look_snr),
            ("max_look_s", self.max_look_s),
            ("speed_m_s", self.speed_m_s),
            ("offset_step_m", self.offset_step_m),
            ("heading_step_rad", self.heading_step_rad),
            ("place_floor_m", self.place_floor_m),
            ("heading_tolerance_rad", self.heading_tolerance_rad),
            ("seed_separation_m", self.seed_separation_m),
            ("max_time_s", self.max_time_s),
            ("candidate_step_m", self.candidate_step_m),
        ];
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParamsError {
                    field,
                    value,
                    why: "must be a positive number",
                });
            }
        }
        let fractions = [
            ("p_detect", self.p_detect),
            ("p_false", self.p_false),
            ("prior_absent", self.prior_absent),
            ("found_probability", self.found_probability),
            ("heading_confidence", self.heading_confidence),
            ("absent_probability", self.absent_probability),
        ];
        for (field, value) in fractions {
            if !(value > 0.0 && value < 1.0) {
                return Err(ParamsError {
                    field,
                    value,
                    why: "must lie strictly between 0 and 1",
                });
            }
        }
        let checks = [
            (
                "max_period_s",
                self.max_period_s,
                self.max_period_s > self.min_period_s,
                "must exceed min_period_s",
            ),
            (
                "first_look_s",
                self.first_look_s,
                self.first_look_s >= 2.5 * self.max_period_s,
                "must hold 2.5 of the longest periods",
            ),
            (
                "look_periods",
                self.look_periods,
                self.look_periods >= 2.0,
                "must be at least 2 periods",
            ),
            (
                "settle_s",
                self.settle_s,
                self.settle_s.is_finite() && self.settle_s >= 0.0,
                "must be zero or positive",
            ),
            (
                "edge_margin_m",
                self.edge_margin_m,
                self.edge_margin_m.is_finite() && self.edge_margin_m >= 0.0,
                "must be zero or positive",
            ),
            (
                "max_heading_rad",
                self.max_heading_rad,
                (0.0..=80f64.to_radians()).contains(&self.max_heading_rad),
                "must lie within 0 to 80 degrees",
            ),
            (
                "p_false",
                self.p_false,
                self.p_false < self.p_detect,
                "must be below p_detect",
            ),
        ];
        for (field, value, ok, why) in checks {
            if !ok {
                return Err(ParamsError { field, value, why });
            }
        }
        Ok(())
    }
}
