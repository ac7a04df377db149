//! The detector's threshold from its own noise-only law, measured: the detector is run on
//! frames of unit normals (the caller draws them: this crate has no random numbers) and the
//! largest log ratio it reaches by each segment end is kept. A window of length `L` alarms
//! falsely when that running maximum at `L` crosses the threshold, so the threshold for a
//! false-alarm rate `pfa` is its `1 − pfa` quantile at `L`: one measurement serves every
//! window length up to the longest.
//!
//! The statistic scales itself by the noise it measures, so unit normals stand for any
//! noise level; what the law does depend on (rates, bins, positions, segment, waveform)
//! is fixed by the settings the threshold carries.

use super::{PulseShape, WeakPulseDetector, WeakPulseError, WeakPulseSettings};
use crate::types::TactileFrame;

/// The running maximum of the log ratio at each segment end, over noise-only draws.
#[derive(Debug, Clone)]
pub struct NoiseLaw {
    settings: WeakPulseSettings,
    shape: PulseShape,
    /// `running_max[k][d]`: draw `d`'s largest log ratio over the first `k + 1` segments.
    running_max: Vec<Vec<f64>>,
}

/// A threshold on the log ratio for a false-alarm rate over windows of `limit_s`.
#[derive(Debug, Clone, PartialEq)]
pub struct Threshold {
    pub log_ratio: f64,
    pub limit_s: f64,
    pub pfa: f64,
    pub(super) settings: WeakPulseSettings,
    pub(super) shape: PulseShape,
}

impl NoiseLaw {
    /// Run `draws` noise-only windows of `settings.limit_s`.
    pub fn measure(
        settings: &WeakPulseSettings,
        shape: &PulseShape,
        draws: usize,
        normal: &mut impl FnMut() -> f64,
    ) -> Result<Self, WeakPulseError> {
        if draws < 10 {
            return Err(WeakPulseError::Calibration(format!(
                "at least 10 draws are needed, got {draws}"
            )));
        }
        let looks = settings.looks(settings.limit_s);
        let dt = 1.0 / settings.geometry.sample_rate_hz;
        let mut running_max = vec![Vec::with_capacity(draws); looks];
        for _ in 0..draws {
            let mut detector =
                WeakPulseDetector::build(settings.clone(), shape.clone(), f64::INFINITY, looks)?;
            let mut top = f64::NEG_INFINITY;
            let mut i = 0u64;
            while detector.segments_done() < looks {
                let frame = TactileFrame {
                    t_s: i as f64 * dt,
                    seq: i,
                    force_n: std::array::from_fn(|_| normal()),
                };
                i += 1;
                let before = detector.segments_done();
                match detector.push(&frame) {
                    Ok(_) => {}
                    Err(e) => {
                        return Err(WeakPulseError::Calibration(format!(
                            "noise-only frame refused: {e}"
                        )));
                    }
                }
                if detector.segments_done() > before {
                    top = top.max(detector.log_ratio_now());
                    running_max[detector.segments_done() - 1].push(top);
                }
            }
        }
        Ok(Self {
            settings: settings.clone(),
            shape: shape.clone(),
            running_max,
        })
    }

    /// The threshold for false-alarm rate `pfa` over windows of `limit_s` (at most the
    /// measured limit).
    pub fn threshold(&self, pfa: f64, limit_s: f64) -> Result<Threshold, WeakPulseError> {
        if !(pfa > 0.0 && pfa < 1.0) {
            return Err(WeakPulseError::Setting {
                what: "false-alarm rate",
                rule: "between 0 and 1",
                value: pfa,
            });
        }
        if !(limit_s.is_finite() && limit_s > 0.0 && limit_s <= self.settings.limit_s) {
            return Err(WeakPulseError::Setting {
                what: "window limit",
                rule: "positive and at most the limit the noise law was measured to",
                value: limit_s,
            });
        }
        let column = &self.running_max[self.settings.looks(limit_s) - 1];
        let draws = column.len();
        if (draws as f64) * pfa < 10.0 {
            return Err(WeakPulseError::Setting {
                what: "draws x false-alarm rate",
                rule: "at least 10 (too few false alarms to place the threshold)",
                value: draws as f64 * pfa,
            });
        }
        let mut sorted = column.clone();
        sorted.sort_by(f64::total_cmp);
        let k = (((1.0 - pfa) * draws as f64).ceil() as usize).min(draws - 1);
        Ok(Threshold {
            log_ratio: sorted[k],
            limit_s,
            pfa,
            settings: self.settings.clone(),
            shape: self.shape.clone(),
        })
    }

    /// Draws measured.
    pub fn draws(&self) -> usize {
        self.running_max.first().map_or(0, Vec::len)
    }
}
