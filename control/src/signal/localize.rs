//! Localization on the array (the seed's equation 4): which elements lie over the artery.
//!
//! For every element, the mean of `samples` samples centred at a pulse peak and the mean of
//! as many centred halfway between peaks (near the pressure minimum). An element is "on
//! the artery" if peak mean − off-peak mean exceeds `sigma_factor × σ`, σ being one
//! element's noise SD. The seed applies the test to the maximally changing element and
//! localizes "to within one or two sensor elements"; we apply it to every element and
//! report the contiguous passing run that contains `i*`, at the centre of that run. Far
//! elements that move out of phase (the sensor lifting off beside the artery) have a
//! negative difference and never pass. If `i*` itself fails, the artery is not located.

use super::window::Channels;
use crate::types::ELEMENTS;

/// Settings of the test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalizerSettings {
    /// Samples per mean (the seed: 15).
    pub samples_per_mean: usize,
    /// Threshold in noise SDs (the seed: 2).
    pub sigma_factor: f64,
    /// Noise SD of one element, N (the seed: 0.012 N).
    pub noise_sd_n: f64,
}

/// Where the artery lies on the array.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Localization {
    /// Centre of the passing run containing `i*`, element index (x.5 when the run has an
    /// even number of elements).
    pub element: f64,
    /// First and last element of that run.
    pub first: usize,
    pub last: usize,
    /// Peak − off-peak of `i*`, N.
    pub amplitude_n: f64,
    /// Peak − off-peak of every element, N.
    pub contrast_n: [f64; ELEMENTS],
}

/// Why the artery was not located.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum NotLocated {
    #[error("the window is empty")]
    Empty,
    #[error(
        "element {element}: peak − off-peak {contrast_n:.4} N does not exceed {threshold_n:.4} N"
    )]
    BelowThreshold {
        element: usize,
        contrast_n: f64,
        threshold_n: f64,
    },
}

/// Mean of `count` consecutive samples centred at (fractional) index `centre`, shifted to
/// lie inside the series; the whole series if it is shorter than `count`.
pub fn centred_mean(series: &[f64], centre: f64, count: usize) -> Option<f64> {
    let n = series.len();
    if n == 0 {
        return None;
    }
    let count = count.clamp(1, n);
    let start = (centre - (count as f64 - 1.0) / 2.0).round();
    let start = if start.is_finite() {
        (start.max(0.0) as usize).min(n - count)
    } else {
        0
    };
    Some(series[start..start + count].iter().sum::<f64>() / count as f64)
}

/// Localize given the strongest element `i_star`, a peak index and an off-peak index
/// (fractional sample indices into the window).
pub fn localize(
    channels: &Channels<'_>,
    i_star: usize,
    peak: f64,
    off_peak: f64,
    settings: &LocalizerSettings,
) -> Result<Localization, NotLocated> {
    let i_star = i_star.min(ELEMENTS - 1);
    let mut contrast_n = [0.0; ELEMENTS];
    for (e, c) in contrast_n.iter_mut().enumerate() {
        let series = channels.element(e);
        let high =
            centred_mean(series, peak, settings.samples_per_mean).ok_or(NotLocated::Empty)?;
        let low =
            centred_mean(series, off_peak, settings.samples_per_mean).ok_or(NotLocated::Empty)?;
        *c = high - low;
    }
    let threshold_n = settings.sigma_factor * settings.noise_sd_n;
    let passes = |e: usize| contrast_n[e] > threshold_n;
    if !passes(i_star) {
        return Err(NotLocated::BelowThreshold {
            element: i_star,
            contrast_n: contrast_n[i_star],
            threshold_n,
        });
    }
    let mut first = i_star;
    while first > 0 && passes(first - 1) {
        first -= 1;
    }
    let mut last = i_star;
    while last + 1 < ELEMENTS && passes(last + 1) {
        last += 1;
    }
    Ok(Localization {
        element: (first + last) as f64 / 2.0,
        first,
        last,
        amplitude_n: contrast_n[i_star],
        contrast_n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centred_mean_shifts_inside_the_series() {
        let s: Vec<f64> = (0..10).map(f64::from).collect();
        assert_eq!(centred_mean(&s, 5.0, 3), Some(5.0));
        assert_eq!(centred_mean(&s, 0.0, 3), Some(1.0));
        assert_eq!(centred_mean(&s, 9.0, 3), Some(8.0));
        assert_eq!(centred_mean(&s, 4.0, 50), Some(4.5));
        assert_eq!(centred_mean(&s, f64::NAN, 2), Some(0.5));
        assert_eq!(centred_mean(&[], 0.0, 2), None);
    }
}
