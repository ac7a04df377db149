//! One touch of the tissue surface: where the sensor met it, from the contact force read
//! while the sensor comes down slowly from above.
//!
//! The sensor first rests above the surface, where the summed force is the array's offset
//! (the **baseline**: its median, and its noise from the median absolute deviation). It then
//! descends, every frame kept, until the force has risen `stop_n` (at least 6 noise SDs)
//! above the baseline. The surface is the knee of a **hinge** fitted to the whole descent by
//! least squares: force = a above h₀ and a + k (h₀ − height) below it, h₀ tried at every
//! frame's height. Where the force starts to rise, not where it crossed a threshold: a
//! threshold's height is biased by threshold / stiffness, and on an array whose summed
//! element force rises only ~100 N/m (the simulator's foam under a 34 mm cylinder) that bias
//! is a millimetre per 0.1 N. The array's gain errors scale the force, not its knee.
//! Tissue stiffens as it is pressed (Hertzian contact), which a straight hinge reads as a
//! knee a little deep; `stop_n` keeps the pressed part short.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The touches' thresholds and motions (config `calibration.tissue`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TouchSettings {
    /// Frames at rest above the surface before the baseline starts: a heavy tip on a
    /// compliant rod swings for a while after a long move.
    pub settle_frames: usize,
    /// Frames at rest above the surface that make the baseline.
    pub baseline_frames: usize,
    /// Least force above the baseline that counts as touching, N (raised to 4 baseline
    /// SDs): a descent that never gets this far has met no surface.
    pub start_n: f64,
    /// Force above the baseline where the descent ends and the hinge is fitted, N (raised
    /// to 6 baseline SDs; at least twice `start_n`).
    pub stop_n: f64,
    /// How far above the configured surface the sensor travels between touches, m.
    pub clearance_m: f64,
    /// How far below the configured surface a descent goes before it gives up, m.
    pub search_depth_m: f64,
    /// Speed of the descent onto the surface, m/s: slow enough for several frames in the
    /// fit window (0.12 N over 1000 N/m is 0.12 mm: 60 frames at 2 mm/s and 1 kHz).
    pub descent_speed_m_s: f64,
}

impl Default for TouchSettings {
    fn default() -> Self {
        Self {
            settle_frames: 100,
            baseline_frames: 50,
            start_n: 0.05,
            stop_n: 0.25,
            clearance_m: 0.008,
            search_depth_m: 0.008,
            descent_speed_m_s: 0.002,
        }
    }
}

impl TouchSettings {
    pub fn check(&self) -> Result<(), String> {
        if self.baseline_frames < 5 {
            return Err(format!(
                "baseline_frames must be at least 5, got {}",
                self.baseline_frames
            ));
        }
        if !(self.start_n.is_finite() && self.start_n > 0.0) {
            return Err(format!(
                "start_n must be positive and finite, got {}",
                self.start_n
            ));
        }
        if !(self.stop_n.is_finite() && self.stop_n >= 2.0 * self.start_n) {
            return Err(format!(
                "stop_n must be at least twice start_n ({}), got {}",
                self.start_n, self.stop_n
            ));
        }
        for (name, v, most) in [
            ("clearance_m", self.clearance_m, 0.05),
            ("search_depth_m", self.search_depth_m, 0.03),
            ("descent_speed_m_s", self.descent_speed_m_s, 0.01),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= most) {
                return Err(format!("{name} must be in (0, {most}], got {v}"));
            }
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum TouchError {
    #[error("a sample is not finite (height {height_m} m, force {force_n} N)")]
    NonFinite { height_m: f64, force_n: f64 },
    #[error(
        "the force rose only {most_n:.3} N above its baseline (noise SD {sd_n:.3} N), the \
         sensor down to {lowest_m:.4} m: no surface met"
    )]
    NoSurface {
        most_n: f64,
        sd_n: f64,
        lowest_m: f64,
    },
    #[error(
        "the force did not rise as the sensor went down (best hinge slope {slope_n_per_m:.1} \
         N/m over {samples} frames): not a surface"
    )]
    NotASurface { slope_n_per_m: f64, samples: usize },
}

/// Where the surface was met.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// The sensor-centre height of zero contact force, m (the height coordinate fed in).
    pub surface_height_m: f64,
    /// The contact stiffness the fit found, N/m.
    pub stiffness_n_per_m: f64,
    /// RMS force residual of the hinge over the descent, N.
    pub rms_residual_n: f64,
    /// Frames of the descent below the knee (in contact).
    pub samples: usize,
    pub baseline_n: f64,
    pub baseline_sd_n: f64,
    /// The sensor's height while the baseline was taken, m (median): a surface met less
    /// than a millimetre below it was touched at rest already.
    pub rest_height_m: f64,
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    /// Frames still to skip before the baseline.
    Settling(usize),
    /// Forces and heights at rest.
    Baseline(Vec<f64>, Vec<f64>),
    Descending {
        baseline_n: f64,
        baseline_sd_n: f64,
        rest_height_m: f64,
        stop_n: f64,
        /// Every frame of the descent: height, force above the baseline.
        samples: Vec<(f64, f64)>,
        most_n: f64,
        lowest_m: f64,
    },
    Done,
}

/// Fed one frame at a time: the summed force and the sensor's height at that frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceTouch {
    settings: TouchSettings,
    phase: Phase,
}

impl SurfaceTouch {
    pub fn new(settings: TouchSettings) -> Result<Self, String> {
        settings.check()?;
        Ok(Self {
            settings,
            phase: Phase::Settling(settings.settle_frames),
        })
    }

    /// The baseline is recorded: the sensor may start down.
    pub fn ready(&self) -> bool {
        !matches!(self.phase, Phase::Settling(_) | Phase::Baseline(..))
    }

    /// The baseline's noise SD, N, once there is a baseline.
    pub fn baseline_sd_n(&self) -> Option<f64> {
        match &self.phase {
            Phase::Descending { baseline_sd_n, .. } => Some(*baseline_sd_n),
            _ => None,
        }
    }

    /// One frame. `Some` once, when the touch is found or cannot be.
    pub fn push(&mut self, height_m: f64, force_n: f64) -> Option<Result<Touch, TouchError>> {
        if !(height_m.is_finite() && force_n.is_finite()) {
            self.phase = Phase::Done;
            return Some(Err(TouchError::NonFinite { height_m, force_n }));
        }
        match &mut self.phase {
            Phase::Settling(left) => {
                if *left <= 1 {
                    let n = self.settings.baseline_frames;
                    self.phase = Phase::Baseline(Vec::with_capacity(n), Vec::with_capacity(n));
                } else {
                    *left -= 1;
                }
                None
            }
            Phase::Baseline(forces, heights) => {
                forces.push(force_n);
                heights.push(height_m);
                if forces.len() >= self.settings.baseline_frames {
                    let (median, sd) = median_sd(forces);
                    let rest_height_m = median_sd(heights).0;
                    let start_n = self.settings.start_n.max(4.0 * sd);
                    self.phase = Phase::Descending {
                        baseline_n: median,
                        baseline_sd_n: sd,
                        rest_height_m,
                        stop_n: self.settings.stop_n.max(6.0 * sd).max(2.0 * start_n),
                        samples: Vec::new(),
                        most_n: f64::NEG_INFINITY,
                        lowest_m: f64::INFINITY,
                    };
                }
                None
            }
            Phase::Descending {
                baseline_n,
                stop_n,
                samples,
                most_n,
                lowest_m,
                ..
            } => {
                let excess = force_n - *baseline_n;
                samples.push((height_m, excess));
                *most_n = most_n.max(excess);
                *lowest_m = lowest_m.min(height_m);
                if excess < *stop_n {
                    return None;
                }
                Some(self.finish())
            }
            Phase::Done => None,
        }
    }

    /// End the touch now (the descent went as far as it may): the hinge if the force rose
    /// past `start_n` (4 noise SDs at least), else no surface.
    pub fn finish(&mut self) -> Result<Touch, TouchError> {
        let phase = std::mem::replace(&mut self.phase, Phase::Done);
        let Phase::Descending {
            baseline_n,
            baseline_sd_n,
            rest_height_m,
            samples,
            most_n,
            lowest_m,
            ..
        } = phase
        else {
            return Err(TouchError::NoSurface {
                most_n: 0.0,
                sd_n: f64::NAN,
                lowest_m: f64::NAN,
            });
        };
        let start_n = self.settings.start_n.max(4.0 * baseline_sd_n);
        if most_n.partial_cmp(&start_n) != Some(std::cmp::Ordering::Greater) {
            return Err(TouchError::NoSurface {
                most_n,
                sd_n: baseline_sd_n,
                lowest_m,
            });
        }
        fit_hinge(&samples, baseline_n, baseline_sd_n).map(|t| Touch { rest_height_m, ..t })
    }
}

/// The hinge force = a + k · max(0, h₀ − h) with the least squared residual over `samples`,
/// h₀ tried at each sample's height with at least 3 frames on either side.
fn fit_hinge(
    samples: &[(f64, f64)],
    baseline_n: f64,
    baseline_sd_n: f64,
) -> Result<Touch, TouchError> {
    let n = samples.len();
    let mut heights: Vec<f64> = samples.iter().map(|s| s.0).collect();
    heights.sort_by(f64::total_cmp);
    heights.dedup();
    let mut best: Option<(f64, f64, f64, usize)> = None; // (rss, h0, k, in contact)
    let mut best_slope = f64::NEG_INFINITY;
    for &h0 in &heights {
        let (mut sx, mut sy, mut sxx, mut sxy, mut below) = (0.0, 0.0, 0.0, 0.0, 0usize);
        for &(h, f) in samples {
            let x = (h0 - h).max(0.0);
            if h < h0 {
                below += 1;
            }
            sx += x;
            sy += f;
            sxx += x * x;
            sxy += x * f;
        }
        if below < 3 || n - below < 3 {
            continue;
        }
        let nf = n as f64;
        let det = nf * sxx - sx * sx;
        if det.is_nan() || det <= 0.0 {
            continue;
        }
        let k = (nf * sxy - sx * sy) / det;
        let a = (sy - k * sx) / nf;
        best_slope = best_slope.max(k);
        if k.is_nan() || k <= 0.0 {
            continue;
        }
        let rss: f64 = samples
            .iter()
            .map(|&(h, f)| (f - a - k * (h0 - h).max(0.0)).powi(2))
            .sum();
        if best.is_none_or(|b| rss < b.0) {
            best = Some((rss, h0, k, below));
        }
    }
    match best {
        Some((rss, h0, k, below)) => Ok(Touch {
            surface_height_m: h0,
            stiffness_n_per_m: k,
            rms_residual_n: (rss / n as f64).sqrt(),
            samples: below,
            baseline_n,
            baseline_sd_n,
            rest_height_m: f64::NAN,
        }),
        None => Err(TouchError::NotASurface {
            slope_n_per_m: best_slope,
            samples: n,
        }),
    }
}

/// The median and the SD from the median absolute deviation: a frame's glitch or a knock
/// while resting must not raise the thresholds past the force the touch reaches.
fn median_sd(v: &[f64]) -> (f64, f64) {
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        }
    };
    let mut sorted = v.to_vec();
    let m = median(&mut sorted);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    (m, 1.4826 * median(&mut dev))
}

#[cfg(test)]
#[path = "touch_tests.rs"]
mod tests;
