//! Pass or fail of a calibration result: each result reports its quantities (residual, spread,
//! tilt, gain error) as [`Check`]s against the limits configured in [`Tolerances`].

use std::fmt;

use serde::{Deserialize, Serialize};

/// Which side of the limit passes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Bound {
    /// The value must not exceed the limit (a residual, an error).
    AtMost,
    /// The value must reach the limit (a spread that conditions a fit).
    AtLeast,
}

/// One quantity of a calibration result against its tolerance. A NaN value never passes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Check {
    /// What was measured, e.g. "pivot RMS residual".
    pub quantity: &'static str,
    pub value: f64,
    pub bound: Bound,
    pub limit: f64,
    /// SI unit of `value` and `limit` ("m", "rad", "" for a ratio or a count).
    pub unit: &'static str,
}

impl Check {
    pub fn at_most(quantity: &'static str, value: f64, limit: f64, unit: &'static str) -> Self {
        Self {
            quantity,
            value,
            bound: Bound::AtMost,
            limit,
            unit,
        }
    }

    pub fn at_least(quantity: &'static str, value: f64, limit: f64, unit: &'static str) -> Self {
        Self {
            quantity,
            value,
            bound: Bound::AtLeast,
            limit,
            unit,
        }
    }

    pub fn passed(&self) -> bool {
        match self.bound {
            Bound::AtMost => self.value <= self.limit,
            Bound::AtLeast => self.value >= self.limit,
        }
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (op, verdict) = match (self.bound, self.passed()) {
            (Bound::AtMost, true) => ("≤", "pass"),
            (Bound::AtMost, false) => ("is not ≤", "FAIL"),
            (Bound::AtLeast, true) => ("≥", "pass"),
            (Bound::AtLeast, false) => ("is not ≥", "FAIL"),
        };
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        write!(
            f,
            "{} {:.6e}{unit} {op} {:.6e}{unit}: {verdict}",
            self.quantity, self.value, self.limit
        )
    }
}

/// True if every check passed (and there is at least one).
pub fn all_passed(checks: &[Check]) -> bool {
    !checks.is_empty() && checks.iter().all(Check::passed)
}

/// Configured limits for the calibration results. The defaults and their reasons are in
/// docs/calibration.md ("Rig calibration").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Tolerances {
    /// Largest RMS distance of the fitted pivot from the rod lines, m.
    pub pivot_max_rms_residual_m: f64,
    /// Smallest spread of the rod directions about their common axis, rad: below it the
    /// pivot along that axis is fixed mainly by noise (the fit is ill-conditioned).
    pub pivot_min_spread_rad: f64,
    /// Largest RMS distance of the touched points from the fitted surface plane, m.
    pub tissue_max_rms_residual_m: f64,
    /// Largest tilt of the surface from level, rad (the kinematics' tissue frame is level).
    pub tissue_max_tilt_rad: f64,
    /// Largest relative standard error of a usable element's gain.
    pub tactile_max_gain_relative_error: f64,
    /// Most elements the localization may have to skip (dead, stuck, saturated).
    pub tactile_max_unusable_elements: usize,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            pivot_max_rms_residual_m: 0.5e-3,
            pivot_min_spread_rad: 0.1,
            tissue_max_rms_residual_m: 0.5e-3,
            tissue_max_tilt_rad: 0.02,
            tactile_max_gain_relative_error: 0.05,
            tactile_max_unusable_elements: 1,
        }
    }
}

impl Tolerances {
    /// Refuse limits no result could be judged by (non-finite, negative, or a spread that
    /// cannot be reached).
    pub fn check(&self) -> Result<(), String> {
        let positive = [
            ("pivot_max_rms_residual_m", self.pivot_max_rms_residual_m),
            ("pivot_min_spread_rad", self.pivot_min_spread_rad),
            ("tissue_max_rms_residual_m", self.tissue_max_rms_residual_m),
            ("tissue_max_tilt_rad", self.tissue_max_tilt_rad),
            (
                "tactile_max_gain_relative_error",
                self.tactile_max_gain_relative_error,
            ),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be positive and finite, got {v}"));
            }
        }
        // The spread, asin √(λmin/n), cannot exceed asin √(2/3): the normal matrix's trace is
        // 2n, so its smallest eigenvalue is at most 2n/3 (directions spread evenly).
        let most = (2.0f64 / 3.0).sqrt().asin();
        if self.pivot_min_spread_rad >= most {
            return Err(format!(
                "pivot_min_spread_rad must be below {most:.4} rad (no set of rods spreads \
                 more), got {}",
                self.pivot_min_spread_rad
            ));
        }
        if self.tissue_max_tilt_rad >= std::f64::consts::FRAC_PI_2 {
            return Err(format!(
                "tissue_max_tilt_rad must be below π/2, got {}",
                self.tissue_max_tilt_rad
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_pass_on_their_side_of_the_limit_and_nan_never_passes() {
        assert!(Check::at_most("r", 1.0, 1.0, "m").passed());
        assert!(!Check::at_most("r", 1.0 + 1e-12, 1.0, "m").passed());
        assert!(Check::at_least("s", 0.1, 0.1, "rad").passed());
        assert!(!Check::at_least("s", 0.0999, 0.1, "rad").passed());
        assert!(!Check::at_most("r", f64::NAN, 1.0, "m").passed());
        assert!(!Check::at_least("s", f64::NAN, 0.1, "rad").passed());
    }

    #[test]
    fn all_passed_needs_every_check_and_at_least_one() {
        let ok = Check::at_most("a", 0.0, 1.0, "m");
        let bad = Check::at_most("b", 2.0, 1.0, "m");
        assert!(all_passed(&[ok, ok]));
        assert!(!all_passed(&[ok, bad]));
        assert!(!all_passed(&[]));
    }

    #[test]
    fn a_check_reads_as_its_quantity_value_limit_and_verdict() {
        let text = Check::at_most("pivot RMS residual", 2e-3, 1e-3, "m").to_string();
        assert!(
            text.starts_with("pivot RMS residual 2.000000e-3 m"),
            "{text}"
        );
        assert!(text.ends_with("FAIL"), "{text}");
        let text = Check::at_least("count", 3.0, 1.0, "").to_string();
        assert_eq!(text, "count 3.000000e0 ≥ 1.000000e0: pass");
    }

    #[test]
    fn tolerances_refuse_limits_nothing_could_be_judged_by() {
        assert!(Tolerances::default().check().is_ok());
        let widest = Tolerances {
            pivot_min_spread_rad: 0.955,
            ..Default::default()
        };
        assert!(widest.check().is_ok());
        let bad = [
            Tolerances {
                pivot_max_rms_residual_m: 0.0,
                ..Default::default()
            },
            Tolerances {
                pivot_min_spread_rad: f64::NAN,
                ..Default::default()
            },
            Tolerances {
                pivot_min_spread_rad: 0.96,
                ..Default::default()
            },
            Tolerances {
                tissue_max_rms_residual_m: -1e-3,
                ..Default::default()
            },
            Tolerances {
                tissue_max_tilt_rad: f64::INFINITY,
                ..Default::default()
            },
            Tolerances {
                tissue_max_tilt_rad: 1.6,
                ..Default::default()
            },
            Tolerances {
                tactile_max_gain_relative_error: 0.0,
                ..Default::default()
            },
        ];
        for t in bad {
            let e = t.check();
            assert!(e.is_err(), "{t:?} accepted");
        }
    }
}
