//! Calibration of the tactile array: tare (each element's offset and noise SD, measured from a
//! no-load recording), each element's gain from a known uniform load, and the elements not to
//! trust (stuck, saturated, dead), marked so that localization skips them.
//!
//! Plain statistics over recorded [`TactileFrame`]s (means, sample SDs with n − 1, extremes;
//! nothing a crate would add). An element is, in this order:
//! - **stuck** if its no-load readings vary by less than `stuck_max_noise_sd_n` (a live
//!   capacitive element always shows noise);
//! - **saturated** if any reading reaches ±`full_scale_n`, or if it goes flat under the load
//!   (clipped at a rail the configuration does not know);
//! - **dead** if its gain (loaded mean − offset) / known force is below `min_gain` (or not a
//!   number: readings so large their sums overflow);
//! - otherwise **good**, corrected as (raw − offset) / gain.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::tolerance::{Check, Tolerances};
use crate::types::{ELEMENTS, TactileFrame};

/// Which recording a problem is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Recording {
    NoLoad,
    Loaded,
}

impl std::fmt::Display for Recording {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Recording::NoLoad => "no-load recording",
            Recording::Loaded => "loaded recording",
        })
    }
}

#[derive(Debug, Clone, PartialEq, Error)]
pub enum TactileCalibrationError {
    #[error("{recording}: {frames} frames, need at least {min}")]
    TooFewFrames {
        recording: Recording,
        frames: usize,
        min: usize,
    },

    #[error("{recording}: frame {frame} (seq {seq}), element {element} is not finite")]
    NonFinite {
        recording: Recording,
        frame: usize,
        seq: u64,
        element: usize,
    },

    #[error("the known load must be a positive force per element, got {force_n} N")]
    InvalidLoad { force_n: f64 },

    #[error("invalid tactile calibration settings: {0}")]
    InvalidSettings(String),
}

/// Thresholds of the element checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TactileSettings {
    /// Fewest frames per recording: the sample SD of n frames is itself uncertain by about
    /// 1/√(2n), 16 % at 20.
    pub min_frames: usize,
    /// A no-load SD below this is no noise at all: the element is stuck, N (one count of the
    /// serial protocol, 0.1 mN, against the seed's 12 mN of noise).
    pub stuck_max_noise_sd_n: f64,
    /// A reading at or beyond ± this is at the element's rail, N (i16::MAX counts of 0.1 mN).
    pub full_scale_n: f64,
    /// Below this gain the element is dead: correcting it would multiply its noise by more
    /// than 1/min_gain.
    pub min_gain: f64,
}

impl Default for TactileSettings {
    fn default() -> Self {
        Self {
            min_frames: 20,
            stuck_max_noise_sd_n: 1e-4,
            full_scale_n: 3.2767,
            min_gain: 0.2,
        }
    }
}

impl TactileSettings {
    pub fn check(&self) -> Result<(), String> {
        if self.min_frames < 2 {
            return Err(format!(
                "min_frames must be at least 2 (an SD needs two), got {}",
                self.min_frames
            ));
        }
        for (name, v) in [
            ("stuck_max_noise_sd_n", self.stuck_max_noise_sd_n),
            ("full_scale_n", self.full_scale_n),
            ("min_gain", self.min_gain),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be positive and finite, got {v}"));
            }
        }
        Ok(())
    }
}

/// Per-element statistics of one recording.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ElementStats {
    mean_n: [f64; ELEMENTS],
    sd_n: [f64; ELEMENTS],
    max_n: [f64; ELEMENTS],
    min_n: [f64; ELEMENTS],
    frames: usize,
}

fn element_stats(
    recording: Recording,
    frames: &[TactileFrame],
    settings: &TactileSettings,
) -> Result<ElementStats, TactileCalibrationError> {
    settings
        .check()
        .map_err(TactileCalibrationError::InvalidSettings)?;
    if frames.len() < settings.min_frames {
        return Err(TactileCalibrationError::TooFewFrames {
            recording,
            frames: frames.len(),
            min: settings.min_frames,
        });
    }
    for (frame, f) in frames.iter().enumerate() {
        if let Some(element) = f.force_n.iter().position(|v| !v.is_finite()) {
            return Err(TactileCalibrationError::NonFinite {
                recording,
                frame,
                seq: f.seq,
                element,
            });
        }
    }
    let n = frames.len() as f64;
    let mut stats = ElementStats {
        mean_n: [0.0; ELEMENTS],
        sd_n: [0.0; ELEMENTS],
        max_n: [f64::NEG_INFINITY; ELEMENTS],
        min_n: [f64::INFINITY; ELEMENTS],
        frames: frames.len(),
    };
    for e in 0..ELEMENTS {
        let mean = frames.iter().map(|f| f.force_n[e]).sum::<f64>() / n;
        // Two passes: the offsets are large against the noise.
        let ss = frames
            .iter()
            .map(|f| (f.force_n[e] - mean).powi(2))
            .sum::<f64>();
        stats.mean_n[e] = mean;
        stats.sd_n[e] = (ss / (n - 1.0)).sqrt();
        stats.max_n[e] = frames
            .iter()
            .map(|f| f.force_n[e])
            .fold(f64::NEG_INFINITY, f64::max);
        stats.min_n[e] = frames
            .iter()
            .map(|f| f.force_n[e])
            .fold(f64::INFINITY, f64::min);
    }
    Ok(stats)
}

/// Offsets and noise of every element at no load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tare {
    stats: ElementStats,
    settings: TactileSettings,
}

impl Tare {
    /// Tare from a no-load recording.
    pub fn from_frames(
        frames: &[TactileFrame],
        settings: &TactileSettings,
    ) -> Result<Self, TactileCalibrationError> {
        Ok(Self {
            stats: element_stats(Recording::NoLoad, frames, settings)?,
            settings: *settings,
        })
    }

    /// Mean reading of each element at no load, N.
    pub fn offset_n(&self) -> [f64; ELEMENTS] {
        self.stats.mean_n
    }

    /// Measured noise SD of each element at no load, N.
    pub fn noise_sd_n(&self) -> [f64; ELEMENTS] {
        self.stats.sd_n
    }

    pub fn frames(&self) -> usize {
        self.stats.frames
    }
}

/// Whether localization may use an element, and if not, why.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ElementStatus {
    Good,
    /// No noise at no load: the reading does not follow anything.
    Stuck,
    /// At the rail, or flat under the load.
    Saturated,
    /// Gain below the settings' `min_gain`: no usable response to the load.
    Dead,
}

impl ElementStatus {
    pub fn is_usable(&self) -> bool {
        *self == ElementStatus::Good
    }
}

/// One element's calibration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElementCalibration {
    /// No-load reading, N.
    pub offset_n: f64,
    /// Measured no-load noise SD, N (of the raw reading).
    pub noise_sd_n: f64,
    /// Reading per newton of load (1 for a perfect element).
    pub gain: f64,
    /// Standard error of the gain from both recordings' noise.
    pub gain_standard_error: f64,
    pub status: ElementStatus,
}

/// The whole array's calibration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TactileCalibration {
    pub elements: [ElementCalibration; ELEMENTS],
    /// The known load the gains refer to, N per element.
    pub known_force_per_element_n: f64,
}

/// Gains from a recording under a known uniform load of `known_force_per_element_n` on every
/// element (a flat plate and a mass: its weight over the elements it covers), after `tare`.
pub fn calibrate_gains(
    tare: &Tare,
    loaded: &[TactileFrame],
    known_force_per_element_n: f64,
) -> Result<TactileCalibration, TactileCalibrationError> {
    if !(known_force_per_element_n.is_finite() && known_force_per_element_n > 0.0) {
        return Err(TactileCalibrationError::InvalidLoad {
            force_n: known_force_per_element_n,
        });
    }
    let settings = &tare.settings;
    let load = element_stats(Recording::Loaded, loaded, settings)?;
    let rest = &tare.stats;
    let elements = std::array::from_fn(|e| {
        let gain = (load.mean_n[e] - rest.mean_n[e]) / known_force_per_element_n;
        let gain_standard_error = (rest.sd_n[e].powi(2) / rest.frames as f64
            + load.sd_n[e].powi(2) / load.frames as f64)
            .sqrt()
            / known_force_per_element_n;
        let status = if rest.sd_n[e] < settings.stuck_max_noise_sd_n {
            ElementStatus::Stuck
        } else if [rest, &load]
            .iter()
            .any(|r| r.max_n[e] >= settings.full_scale_n || r.min_n[e] <= -settings.full_scale_n)
            || load.sd_n[e] < settings.stuck_max_noise_sd_n
        {
            ElementStatus::Saturated
        } else if !(gain >= settings.min_gain && gain_standard_error.is_finite()) {
            ElementStatus::Dead
        } else {
            ElementStatus::Good
        };
        ElementCalibration {
            offset_n: rest.mean_n[e],
            noise_sd_n: rest.sd_n[e],
            gain,
            gain_standard_error,
            status,
        }
    });
    Ok(TactileCalibration {
        elements,
        known_force_per_element_n,
    })
}

impl TactileCalibration {
    /// Which elements localization may use.
    pub fn usable(&self) -> [bool; ELEMENTS] {
        std::array::from_fn(|e| self.elements[e].status.is_usable())
    }

    pub fn unusable_count(&self) -> usize {
        self.usable().iter().filter(|u| !**u).count()
    }

    /// Corrected forces, N: (raw − offset) / gain for usable elements, `None` for the rest
    /// and for a non-finite raw reading.
    pub fn correct(&self, raw_n: &[f64; ELEMENTS]) -> [Option<f64>; ELEMENTS] {
        std::array::from_fn(|e| {
            let c = &self.elements[e];
            (c.status.is_usable() && raw_n[e].is_finite()).then(|| (raw_n[e] - c.offset_n) / c.gain)
        })
    }

    /// Median corrected noise SD (noise SD / gain) over usable elements, N: the one σ the
    /// localization's threshold takes. `None` if no element is usable.
    pub fn noise_sd_n(&self) -> Option<f64> {
        let mut sds: Vec<f64> = self
            .elements
            .iter()
            .filter(|c| c.status.is_usable())
            .map(|c| c.noise_sd_n / c.gain)
            .collect();
        sds.sort_by(f64::total_cmp);
        let m = sds.len();
        match m {
            0 => None,
            _ if m % 2 == 1 => Some(sds[m / 2]),
            _ => Some(0.5 * (sds[m / 2 - 1] + sds[m / 2])),
        }
    }

    /// Largest relative standard error of a usable element's gain (NaN with none usable, so
    /// that its check fails).
    pub fn worst_gain_relative_error(&self) -> f64 {
        self.elements
            .iter()
            .filter(|c| c.status.is_usable())
            .map(|c| c.gain_standard_error / c.gain)
            .fold(f64::NAN, f64::max)
    }

    /// The unusable elements and the gains' precision against their tolerances.
    pub fn checks(&self, tolerances: &Tolerances) -> [Check; 2] {
        [
            Check::at_most(
                "unusable tactile elements",
                self.unusable_count() as f64,
                tolerances.tactile_max_unusable_elements as f64,
                "",
            ),
            Check::at_most(
                "worst relative gain error",
                self.worst_gain_relative_error(),
                tolerances.tactile_max_gain_relative_error,
                "",
            ),
        ]
    }
}

#[cfg(test)]
#[path = "tactile_tests.rs"]
mod tests;
