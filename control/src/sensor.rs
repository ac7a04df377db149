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
    /// Elements not to trust (dead, stuck or saturated, as the tactile calibration marks
    /// them): localization leaves them out instead of reading them as no pulse. A list of
    /// element indices in the config.
    pub skip_elements: ElementMask,
}

/// Fewest elements localization needs: the kernel has four parameters, and two more keep
/// its fit overdetermined.
pub const MIN_TRUSTED_ELEMENTS: usize = 6;

/// A set of element indices (below [`ELEMENTS`]), written as a list of indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(try_from = "Vec<usize>", into = "Vec<usize>")]
pub struct ElementMask(u16);

impl ElementMask {
    pub const NONE: Self = Self(0);

    pub fn contains(&self, element: usize) -> bool {
        element < ELEMENTS && self.0 & (1 << element) != 0
    }

    pub fn len(&self) -> usize {
        self.0.count_ones() as usize
    }

    pub fn is_empty(&self) -> bool {
        self.0 == 0
    }

    /// Every element in either set.
    pub fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    /// 1 for a trusted element, 0 for a skipped one.
    pub fn weights(&self) -> [f64; ELEMENTS] {
        std::array::from_fn(|e| if self.contains(e) { 0.0 } else { 1.0 })
    }
}

impl TryFrom<Vec<usize>> for ElementMask {
    type Error = String;

    fn try_from(elements: Vec<usize>) -> Result<Self, String> {
        let mut bits = 0u16;
        for e in elements {
            if e >= ELEMENTS {
                return Err(format!(
                    "element {e} does not exist (the array has elements 0 to {})",
                    ELEMENTS - 1
                ));
            }
            bits |= 1 << e;
        }
        Ok(Self(bits))
    }
}

impl From<ElementMask> for Vec<usize> {
    fn from(m: ElementMask) -> Self {
        (0..ELEMENTS).filter(|&e| m.contains(e)).collect()
    }
}

impl Default for ArrayGeometry {
    fn default() -> Self {
        Self {
            pitch_m: 0.002,
            direction: 1.0,
            noise_sd_n: 0.012,
            sample_rate_hz: 100.0,
            skip_elements: ElementMask::NONE,
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
        let trusted = ELEMENTS - self.skip_elements.len();
        if trusted < MIN_TRUSTED_ELEMENTS {
            return Err(format!(
                "skip_elements leaves {trusted} elements; localization needs at least \
                 {MIN_TRUSTED_ELEMENTS}"
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
    fn skipped_elements_are_a_list_of_indices_that_exist() {
        let m = ElementMask::try_from(vec![3, 9, 3]).unwrap();
        assert!(m.contains(3) && m.contains(9) && !m.contains(4) && !m.contains(10));
        assert_eq!(m.len(), 2);
        assert_eq!(Vec::<usize>::from(m), vec![3, 9]);
        let e = ElementMask::try_from(vec![10]).unwrap_err();
        assert!(e.contains("element 10") && e.contains("0 to 9"), "{e}");
        assert_eq!(m.weights().iter().sum::<f64>(), 8.0);
        // Five skipped leave five: too few to localize.
        let g = ArrayGeometry {
            skip_elements: ElementMask::try_from(vec![0, 1, 2, 3, 4]).unwrap(),
            ..Default::default()
        };
        let e = g.check().unwrap_err();
        assert!(
            e.contains("skip_elements") && e.contains("5 elements"),
            "{e}"
        );
        let g = ArrayGeometry {
            skip_elements: ElementMask::try_from(vec![0, 1, 2, 3]).unwrap(),
            ..Default::default()
        };
        assert!(g.check().is_ok());
    }

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
