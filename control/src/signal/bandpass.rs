//! The seed's band-pass: a Hamming-windowed FIR (windowed sinc), applied to a whole
//! acquisition window with its group delay removed.
//!
//! The seed filtered each acquisition with "a 4th order Hamming filter with corner
//! frequencies of 0.5 and 2.0 Hz". We read that as a Hamming-windowed FIR (MATLAB's `fir1`
//! design) of configurable order; docs/signal-processing.md shows why a literal 4th order is
//! too short to separate a 1 Hz pulse from drift and noise at 100 Hz, and how the shipped
//! order was measured.
//!
//! Design choices (each explained in docs/signal-processing.md):
//! - The order is even, so the symmetric (type I) FIR has an integer group delay of
//!   `order / 2` samples and is exactly linear phase. Filtering indexes the input
//!   `order / 2` samples ahead, which removes the delay with no phase distortion, so a
//!   pulse centre in the output is at the same time as in the input. Forward-backward
//!   filtering would also be zero-phase but squares the magnitude response (corners at
//!   -12 dB instead of -6 dB) and doubles the edge transients; it buys nothing here.
//! - The taps are corrected to an exact null at DC (subtracting a scaled copy of the
//!   window), then scaled to unit gain at the band's geometric centre `sqrt(low * high)`
//!   (1 Hz for the seed's band, the pulse rate of its model artery).
//! - The window is finite, so the filter needs values beyond its ends. The least-squares
//!   line through the window is removed first (contact force offset and creep drift; a
//!   zero-DC symmetric FIR would map them to zero in the interior anyway), and the rest is
//!   extended by even (mirror) reflection about the end samples. The extension stays within
//!   the window's own range, so edge transients stay small: with odd (point) reflection a
//!   pulse peak at the window's edge continues upward past the peak and the filtered edge
//!   overshoots (measured for 0.9-1.67 Hz sinusoids at all phases, order 128: worst edge
//!   excursion 1.41 times the pulse amplitude with odd reflection, 1.12 with detrending and
//!   even reflection). Edge transients matter because max − min is taken over the whole
//!   window.

use std::f64::consts::PI;

/// What to design.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandPassSpec {
    /// Filter order (taps − 1); must be even and at least 2.
    pub order: usize,
    /// Lower corner, Hz.
    pub low_hz: f64,
    /// Upper corner, Hz.
    pub high_hz: f64,
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
}

/// Why a band-pass could not be designed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterDesignError {
    #[error("filter order must be even and at least 2, got {0}")]
    BadOrder(usize),
    #[error("sample rate must be positive and finite, got {0} Hz")]
    BadSampleRate(f64),
    #[error(
        "band corners must satisfy 0 < low < high < half the sample rate, got {low_hz} to {high_hz} Hz at {sample_rate_hz} Hz"
    )]
    BadBand {
        low_hz: f64,
        high_hz: f64,
        sample_rate_hz: f64,
    },
    #[error("the order-{0} design has no gain at the band centre")]
    NoGainAtCentre(usize),
}

/// A linear-phase FIR band-pass with its taps.
#[derive(Debug, Clone, PartialEq)]
pub struct BandPass {
    spec: BandPassSpec,
    taps: Vec<f64>,
}

impl BandPass {
    /// Design the filter. Allocates the taps once.
    pub fn design(spec: BandPassSpec) -> Result<Self, FilterDesignError> {
        let BandPassSpec {
            order,
            low_hz,
            high_hz,
            sample_rate_hz: fs,
        } = spec;
        if order < 2 || !order.is_multiple_of(2) {
            return Err(FilterDesignError::BadOrder(order));
        }
        if !(fs.is_finite() && fs > 0.0) {
            return Err(FilterDesignError::BadSampleRate(fs));
        }
        let band_ok = low_hz.is_finite()
            && high_hz.is_finite()
            && low_hz > 0.0
            && low_hz < high_hz
            && high_hz < fs / 2.0;
        if !band_ok {
            return Err(FilterDesignError::BadBand {
                low_hz,
                high_hz,
                sample_rate_hz: fs,
            });
        }
        let f1 = low_hz / fs;
        let f2 = high_hz / fs;
        let half = (order / 2) as f64;
        let window: Vec<f64> = (0..=order)
            .map(|n| 0.54 - 0.46 * (2.0 * PI * n as f64 / order as f64).cos())
            .collect();
        let mut taps: Vec<f64> = window
            .iter()
            .enumerate()
            .map(|(n, w)| {
                let k = n as f64 - half;
                w * (ideal_low_pass(f2, k) - ideal_low_pass(f1, k))
            })
            .collect();
        // Exact null at DC: remove the residual DC gain in the window's shape, which keeps
        // the taps symmetric (linear phase) and only touches the response near 0 Hz.
        let dc: f64 = taps.iter().sum();
        let window_sum: f64 = window.iter().sum();
        for (t, w) in taps.iter_mut().zip(&window) {
            *t -= w * dc / window_sum;
        }
        let centre_hz = (low_hz * high_hz).sqrt();
        let gain = amplitude(&taps, centre_hz / fs);
        if !(gain.is_finite() && gain.abs() > 1e-9) {
            return Err(FilterDesignError::NoGainAtCentre(order));
        }
        for t in &mut taps {
            *t /= gain;
        }
        Ok(Self { spec, taps })
    }

    pub fn spec(&self) -> &BandPassSpec {
        &self.spec
    }

    pub fn taps(&self) -> &[f64] {
        &self.taps
    }

    /// Group delay that [`BandPass::apply`] removes, samples.
    pub fn delay_samples(&self) -> usize {
        self.spec.order / 2
    }

    /// Magnitude of the frequency response at `f_hz`.
    pub fn gain_at(&self, f_hz: f64) -> f64 {
        amplitude(&self.taps, f_hz / self.spec.sample_rate_hz).abs()
    }

    /// Filter `input` into `output` (same length) with the group delay removed, after
    /// removing the window's least-squares line and extending it by mirror reflection.
    /// Does not allocate. Mismatched lengths filter the common prefix; an empty input does
    /// nothing.
    pub fn apply(&self, input: &[f64], output: &mut [f64]) {
        let n = input.len().min(output.len());
        if n == 0 {
            return;
        }
        let input = &input[..n];
        let trend = Trend::fit(input);
        let half = self.delay_samples();
        let order = self.spec.order;
        for (i, out) in output[..n].iter_mut().enumerate() {
            // y[i] = sum_k h[k] d[i + half - k], d the detrended input; interior samples
            // need no extension.
            let hi = i + half;
            *out = if hi >= order && hi < n {
                let lo = hi - order;
                self.taps
                    .iter()
                    .zip((lo..=hi).rev())
                    .map(|(h, j)| h * trend.detrended(input, j))
                    .sum()
            } else {
                self.taps
                    .iter()
                    .enumerate()
                    .map(|(k, h)| h * trend.detrended(input, mirrored(n, hi as isize - k as isize)))
                    .sum()
            };
        }
    }
}

/// The least-squares line through a series, `mean + slope (j - centre)`.
#[derive(Debug, Clone, Copy)]
struct Trend {
    mean: f64,
    slope: f64,
    centre: f64,
}

impl Trend {
    fn fit(x: &[f64]) -> Self {
        let n = x.len() as f64;
        let centre = (n - 1.0) / 2.0;
        let mean = x.iter().sum::<f64>() / n;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (j, v) in x.iter().enumerate() {
            let u = j as f64 - centre;
            sxy += u * (v - mean);
            sxx += u * u;
        }
        let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        Self {
            mean,
            slope,
            centre,
        }
    }

    fn detrended(&self, x: &[f64], j: usize) -> f64 {
        x[j] - self.mean - self.slope * (j as f64 - self.centre)
    }
}

/// Impulse response of an ideal low-pass with cut-off `fc` (cycles/sample) at lag `k`.
fn ideal_low_pass(fc: f64, k: f64) -> f64 {
    if k == 0.0 {
        2.0 * fc
    } else {
        (2.0 * PI * fc * k).sin() / (PI * k)
    }
}

/// Real amplitude response of symmetric taps at `f` cycles/sample (the linear phase
/// factor removed).
fn amplitude(taps: &[f64], f: f64) -> f64 {
    let half = (taps.len() - 1) as f64 / 2.0;
    taps.iter()
        .enumerate()
        .map(|(n, h)| h * (2.0 * PI * f * (n as f64 - half)).cos())
        .sum()
}

/// Index `j` of a series of `n` samples reflected about its end samples (mirror
/// reflection, the end sample not repeated); indices still outside after one reflection
/// (windows shorter than half the filter) clamp to the ends.
fn mirrored(n: usize, j: isize) -> usize {
    let last = n as isize - 1;
    let j = if j < 0 {
        -j
    } else if j > last {
        2 * last - j
    } else {
        j
    };
    j.clamp(0, last) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seed_band(order: usize) -> BandPass {
        BandPass::design(BandPassSpec {
            order,
            low_hz: 0.5,
            high_hz: 2.0,
            sample_rate_hz: 100.0,
        })
        .expect("valid design")
    }

    #[test]
    fn refuses_bad_specs() {
        let ok = BandPassSpec {
            order: 64,
            low_hz: 0.5,
            high_hz: 2.0,
            sample_rate_hz: 100.0,
        };
        for bad in [
            BandPassSpec { order: 0, ..ok },
            BandPassSpec { order: 63, ..ok },
            BandPassSpec { low_hz: 2.0, ..ok },
            BandPassSpec { low_hz: 0.0, ..ok },
            BandPassSpec {
                high_hz: 50.0,
                ..ok
            },
            BandPassSpec {
                high_hz: f64::NAN,
                ..ok
            },
            BandPassSpec {
                sample_rate_hz: 0.0,
                ..ok
            },
        ] {
            assert!(BandPass::design(bad).is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn taps_are_symmetric_with_zero_dc_and_unit_centre_gain() {
        for order in [2, 4, 16, 64, 200] {
            let f = seed_band(order);
            let t = f.taps();
            assert_eq!(t.len(), order + 1);
            let scale: f64 = t.iter().map(|v| v.abs()).sum();
            for k in 0..t.len() {
                assert!((t[k] - t[t.len() - 1 - k]).abs() < 1e-15 * scale);
            }
            assert!(t.iter().sum::<f64>().abs() < 1e-12 * scale, "order {order}");
            assert!((f.gain_at(1.0) - 1.0).abs() < 1e-12, "order {order}");
        }
    }

    #[test]
    fn extension_is_mirror_reflection() {
        assert_eq!(mirrored(3, -1), 1);
        assert_eq!(mirrored(3, -2), 2);
        assert_eq!(mirrored(3, 3), 1);
        assert_eq!(mirrored(3, 4), 0);
        // Beyond one reflection: clamp, never index out of bounds.
        assert_eq!(mirrored(3, -10), 2);
        assert_eq!(mirrored(3, 10), 0);
        assert_eq!(mirrored(1, 5), 0);
    }

    #[test]
    fn trend_is_the_least_squares_line() {
        let x: Vec<f64> = (0..7).map(|j| 3.0 - 0.5 * j as f64).collect();
        let t = Trend::fit(&x);
        for j in 0..7 {
            assert!(t.detrended(&x, j).abs() < 1e-14);
        }
        let single = Trend::fit(&[2.0]);
        assert_eq!(single.detrended(&[2.0], 0), 0.0);
    }
}
