//! Every constant of the seed's tracker (Beasley & Howe 2002), with the seed's value as default.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Seed2002Params {
    /// First acquisition at a new artery (the seed: 4 s at 100 Hz).
    pub first_window_s: f64,
    /// Each later acquisition (the seed: 3 s).
    pub window_s: f64,
    /// Band-pass corners (the seed: 0.5 and 2.0 Hz).
    pub band_low_hz: f64,
    pub band_high_hz: f64,
    /// Order of the Hamming-windowed FIR band-pass. The seed says "4th order"; a literal
    /// 4th-order FIR barely separates 1 Hz from DC at 100 Hz, so the shipped default is
    /// chosen by measured detection performance (see docs/).
    pub fir_order: usize,
    /// Accepted pulse periods, s. Not in the seed: a "period" outside the band-pass's own
    /// pass band is filtered noise, not a pulse. Defaults: the band corners (2.0 and 0.5 Hz)
    /// widened by 10 %, which spans the physiological 1.0–1.67 Hz and the model's ~1 Hz.
    pub min_period_s: f64,
    pub max_period_s: f64,
    /// Threshold as a fraction of max − min above min (the seed: 2/3).
    pub threshold_fraction: f64,
    /// Samples averaged at the pulse peak and halfway between peaks (the seed: 15).
    pub samples_per_mean: usize,
    /// An element is on the artery if peak − off-peak mean exceeds this many noise SDs
    /// (the seed: 2).
    pub sigma_factor: f64,
    /// Localize on the band-passed signal (true) or on raw forces (false).
    pub localize_filtered: bool,
    /// Located points used by the linear regression (the seed: up to 4).
    pub regression_points: usize,
    /// Step growth after a success (the seed: 5 %).
    pub step_growth: f64,
    /// Step factor after a failure, applied from the last location where the pulse was
    /// found (the seed: halve).
    pub backtrack_factor: f64,
    /// Acquisitions tried at one target before declaring a miss (the seed: up to 7).
    pub max_acquisitions: usize,
    /// First autonomous step, m; `None` uses the distance between the two seed points.
    pub initial_step_m: Option<f64>,
    /// Below this step the artery is declared lost, m (the seed gives no value; one element
    /// pitch).
    pub min_step_m: f64,
    /// Upper bound on a step, m; `None` lets it grow without bound as the seed did.
    pub max_step_m: Option<f64>,
    /// Speed of moves between targets, m/s (the seed stops to sample; about two minutes
    /// per 26 cm overall).
    pub move_speed_m_s: f64,
}

impl Default for Seed2002Params {
    fn default() -> Self {
        Self {
            first_window_s: 4.0,
            window_s: 3.0,
            band_low_hz: 0.5,
            band_high_hz: 2.0,
            fir_order: 96,
            min_period_s: 0.45,
            max_period_s: 2.2,
            threshold_fraction: 2.0 / 3.0,
            samples_per_mean: 15,
            sigma_factor: 2.0,
            localize_filtered: true,
            regression_points: 4,
            step_growth: 1.05,
            backtrack_factor: 0.5,
            max_acquisitions: 7,
            initial_step_m: None,
            min_step_m: 0.002,
            max_step_m: None,
            move_speed_m_s: 0.01,
        }
    }
}
