//! Geometry of the tactile element line.
//!
//! The elements lie on a line along tissue `z`. Positions are given relative to the *sensor
//! centre*, the middle of the element line, which is the point the motion layer steers.

use serde::{Deserialize, Serialize};

use crate::types::ELEMENTS;

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ArrayGeometry {
    /// Centre-to-centre element spacing, m.
    pub pitch_m: f64,
    /// Which way element indices run along tissue `z`: +1 (element 0 at the most negative
    /// `z`) or -1.
    pub direction: f64,
    /// Noise standard deviation of one element, N (the seed measured 0.012 N).
    pub noise_sd_n: f64,
    /// Frame rate, Hz.
    pub sample_rate_hz: f64,
}

impl Default for ArrayGeometry {
    fn default() -> Self {
        Self {
            pitch_m: 0.002,
            direction: 1.0,
            noise_sd_n: 0.012,
            sample_rate_hz: 100.0,
        }
    }
}

impl ArrayGeometry {
    /// Lateral (`z`) offset from the sensor centre of a possibly fractional element index.
    pub fn offset_z_m(&self, element: f64) -> f64 {
        let middle = (ELEMENTS as f64 - 1.0) / 2.0;
        self.direction * (element - middle) * self.pitch_m
    }

    /// The (fractional) element index under a lateral offset from the sensor centre.
    pub fn element_at(&self, offset_z_m: f64) -> f64 {
        let middle = (ELEMENTS as f64 - 1.0) / 2.0;
        middle + offset_z_m / (self.direction * self.pitch_m)
    }

    /// Refuse a geometry no tracker can work with (every tracker checks it when built).
    pub fn check(&self) -> Result<(), String> {
        let fs = self.sample_rate_hz;
        if !(fs.is_finite() && fs > 0.0) {
            return Err(format!("sample rate must be positive, got {fs} Hz"));
        }
        if !(self.noise_sd_n.is_finite() && self.noise_sd_n > 0.0) {
            return Err(format!(
                "noise SD must be positive, got {} N",
                self.noise_sd_n
            ));
        }
        if !(self.pitch_m.is_finite() && self.pitch_m > 0.0) {
            return Err(format!(
                "element pitch must be positive, got {} m",
                self.pitch_m
            ));
        }
        if self.direction != 1.0 && self.direction != -1.0 {
            return Err(format!(
                "direction must be +1 or -1, got {}",
                self.direction
            ));
        }
        Ok(())
    }

    /// Sampling interval, s.
    pub fn dt_s(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_refuses_what_no_tracker_can_use() {
        assert!(ArrayGeometry::default().check().is_ok());
        let bad = [
            ArrayGeometry {
                sample_rate_hz: 0.0,
                ..Default::default()
            },
            ArrayGeometry {
                noise_sd_n: f64::NAN,
                ..Default::default()
            },
            ArrayGeometry {
                pitch_m: -0.002,
                ..Default::default()
            },
            ArrayGeometry {
                direction: 0.5,
                ..Default::default()
            },
        ];
        for g in bad {
            assert!(g.check().is_err(), "{g:?} accepted");
        }
        let mirrored = ArrayGeometry {
            direction: -1.0,
            ..Default::default()
        };
        assert!(mirrored.check().is_ok());
    }

    #[test]
    fn offsets_are_symmetric_about_the_centre() {
        let g = ArrayGeometry::default();
        assert!((g.offset_z_m(0.0) + 0.009).abs() < 1e-15);
        assert!((g.offset_z_m(9.0) - 0.009).abs() < 1e-15);
        assert!((g.element_at(g.offset_z_m(3.25)) - 3.25).abs() < 1e-12);
        let flipped = ArrayGeometry {
            direction: -1.0,
            ..g
        };
        assert!((flipped.offset_z_m(0.0) - 0.009).abs() < 1e-15);
    }
}
