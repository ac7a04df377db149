//! A tactile calibration in use: checked when it comes back from a file, applied to each
//! frame before a tracker sees it, and folded into the array geometry trackers are built with
//! (its unusable elements skipped, its measured noise in place of the assumed one).

use super::tactile::TactileCalibration;
use crate::sensor::{ArrayGeometry, ElementMask};
use crate::types::{ELEMENTS, TactileFrame};

impl TactileCalibration {
    /// Refuse a calibration no frame could be corrected by: a known load that is not a
    /// positive force, a non-finite number anywhere, or a usable element whose gain is not
    /// positive. Names the element and the field.
    pub fn validate(&self) -> Result<(), String> {
        let f = self.known_force_per_element_n;
        if !(f.is_finite() && f > 0.0) {
            return Err(format!(
                "known_force_per_element_n must be a positive force, got {f} N"
            ));
        }
        for (e, c) in self.elements.iter().enumerate() {
            for (name, v) in [
                ("offset_n", c.offset_n),
                ("noise_sd_n", c.noise_sd_n),
                ("gain", c.gain),
                ("gain_standard_error", c.gain_standard_error),
            ] {
                // An unusable element's gain may be anything its recording gave (NaN for a
                // stuck one is not expected, but it is never used).
                if c.status.is_usable() && !v.is_finite() {
                    return Err(format!("element {e}: {name} is {v}, not a number"));
                }
            }
            if c.status.is_usable() && c.gain <= 0.0 {
                return Err(format!(
                    "element {e}: gain {} is not positive, yet the element is marked good",
                    c.gain
                ));
            }
            if c.status.is_usable() && c.noise_sd_n < 0.0 {
                return Err(format!(
                    "element {e}: noise_sd_n {} is negative",
                    c.noise_sd_n
                ));
            }
        }
        Ok(())
    }

    /// The unusable elements as a mask.
    pub fn unusable_mask(&self) -> ElementMask {
        let unusable: Vec<usize> = (0..ELEMENTS)
            .filter(|&e| !self.elements[e].status.is_usable())
            .collect();
        // Indices below ELEMENTS always make a mask.
        ElementMask::try_from(unusable).unwrap_or(ElementMask::NONE)
    }

    /// `frame` with every usable element corrected to (raw − offset) / gain and every
    /// unusable one set to 0 N (trackers leave skipped elements out; 0 keeps a stray reader
    /// from seeing a dead element's raw numbers as force).
    pub fn correct_frame(&self, frame: &TactileFrame) -> TactileFrame {
        let corrected = self.correct(&frame.force_n);
        TactileFrame {
            force_n: std::array::from_fn(|e| corrected[e].unwrap_or(0.0)),
            ..*frame
        }
    }

    /// The configured geometry with this calibration's unusable elements added to the skipped
    /// ones and its measured noise (median corrected σ over usable elements) as the noise SD.
    /// Refused when too few elements would stay trusted, naming them.
    pub fn geometry(&self, configured: &ArrayGeometry) -> Result<ArrayGeometry, String> {
        let skip = configured.skip_elements.union(self.unusable_mask());
        let noise_sd_n = self
            .noise_sd_n()
            .ok_or("the calibration marks every element unusable")?;
        let g = ArrayGeometry {
            skip_elements: skip,
            noise_sd_n,
            ..*configured
        };
        g.check().map_err(|e| {
            format!(
                "with the calibration's unusable elements skipped too (skipping {:?}): {e}",
                Vec::<usize>::from(skip)
            )
        })?;
        Ok(g)
    }
}
