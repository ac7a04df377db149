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

use super::{
    PulseShape, TABLE_PFAS, WeakPulseDetector, WeakPulseError, WeakPulseSettings, noise_table,
};
use crate::sensor::ArrayGeometry;
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

impl Threshold {
    /// The shipped threshold (`noise_table`) for false-alarm rate `pfa` (one of
    /// [`TABLE_PFAS`]) over windows of `limit_s` (at most the table's 600 s), for a
    /// detector with [`WeakPulseSettings::tabulated`] settings on `geometry` and the
    /// generic waveform. The table was measured on the default array; it serves any array
    /// of the same pitch and frame rate (the law does not depend on the noise level or the
    /// elements' direction, and with elements skipped it is conservative: fewer elements
    /// reach lower maxima under noise alone).
    pub fn tabulated(
        geometry: &ArrayGeometry,
        pfa: f64,
        limit_s: f64,
    ) -> Result<Self, WeakPulseError> {
        let mut settings = WeakPulseSettings::tabulated();
        if geometry.pitch_m != settings.geometry.pitch_m
            || geometry.sample_rate_hz != settings.geometry.sample_rate_hz
        {
            return Err(WeakPulseError::Calibration(format!(
                "the shipped threshold table is for a {} mm pitch at {} Hz, not {} mm at {} Hz: measure a noise law for this array (NoiseLaw::measure)",
                settings.geometry.pitch_m * 1e3,
                settings.geometry.sample_rate_hz,
                geometry.pitch_m * 1e3,
                geometry.sample_rate_hz
            )));
        }
        settings.geometry = *geometry;
        let Some(row) = TABLE_PFAS.iter().position(|&p| p == pfa) else {
            return Err(WeakPulseError::Setting {
                what: "false-alarm rate",
                rule: "one the shipped threshold table holds (0.01 or 0.05)",
                value: pfa,
            });
        };
        if !(limit_s.is_finite() && limit_s > 0.0 && limit_s <= settings.limit_s) {
            return Err(WeakPulseError::Setting {
                what: "window limit",
                rule: "positive and at most the threshold table's 600 s",
                value: limit_s,
            });
        }
        let look = settings.looks(limit_s) - 1;
        let log_ratio = noise_table::THRESHOLDS[row]
            .get(look)
            .copied()
            .ok_or_else(|| WeakPulseError::Calibration("the threshold table is short".into()))?;
        Ok(Self {
            log_ratio,
            limit_s,
            pfa,
            settings,
            shape: PulseShape::Generic,
        })
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_normals::Normals;

    #[test]
    fn the_shipped_table_is_a_running_maximums_quantiles() {
        let rows = &noise_table::THRESHOLDS;
        assert_eq!(rows.len(), TABLE_PFAS.len());
        let settings = WeakPulseSettings::tabulated();
        assert_eq!(rows[0].len(), settings.looks(settings.limit_s));
        // Enough false alarms among the draws to place each threshold.
        assert!(
            TABLE_PFAS
                .iter()
                .all(|&p| noise_table::DRAWS as f64 * p >= 10.0)
        );
        for (row, &pfa) in rows.iter().zip(&TABLE_PFAS) {
            // A running maximum's quantile never falls as the window grows.
            assert!(row.windows(2).all(|w| w[1] >= w[0]), "pfa {pfa}");
            assert!(row.iter().all(|t| t.is_finite()), "pfa {pfa}");
        }
        // A lower false-alarm rate needs more evidence.
        assert!(rows[0].iter().zip(&rows[1]).all(|(a, b)| a >= b));
    }

    #[test]
    fn fresh_noise_alarms_at_the_tables_rate() {
        // Re-measured on draws the table never saw (its seed was 1818): the share of 45 s
        // noise-only windows that cross the table's threshold for pfa 0.05.
        let limit_s = 45.0;
        let settings = WeakPulseSettings {
            limit_s,
            ..WeakPulseSettings::tabulated()
        };
        let draws = 600;
        let mut rng = Normals::new(77);
        let law = NoiseLaw::measure(&settings, &PulseShape::Generic, draws, &mut || rng.next())
            .expect("noise law");
        let threshold = Threshold::tabulated(&settings.geometry, 0.05, limit_s).expect("table");
        let column = &law.running_max[settings.looks(limit_s) - 1];
        let alarms = column.iter().filter(|&&m| m > threshold.log_ratio).count();
        let rate = alarms as f64 / draws as f64;
        // Four standard errors: the binomial error of these draws and of the table's own
        // quantile over its draws.
        let se = (0.05 * 0.95 * (1.0 / draws as f64 + 1.0 / noise_table::DRAWS as f64)).sqrt();
        assert!(
            (rate - 0.05).abs() < 4.0 * se,
            "false-alarm rate {rate} (SE {se})"
        );
    }

    #[test]
    fn the_table_refuses_other_arrays_rates_and_windows() {
        let g = WeakPulseSettings::tabulated().geometry;
        assert!(Threshold::tabulated(&g, 0.05, 600.0).is_ok());
        assert!(Threshold::tabulated(&g, 0.02, 60.0).is_err());
        assert!(Threshold::tabulated(&g, 0.05, 601.0).is_err());
        assert!(Threshold::tabulated(&g, 0.05, f64::NAN).is_err());
        let other = ArrayGeometry {
            sample_rate_hz: 200.0,
            ..g
        };
        let e = Threshold::tabulated(&other, 0.05, 60.0).expect_err("another array");
        assert!(e.to_string().contains("200 Hz"), "{e}");
    }
}
