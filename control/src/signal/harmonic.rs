//! Lock-in by least squares: every element's samples fitted with a constant, a linear trend
//! and the first [`HARMONICS`] harmonics of a known pulse phase.
//!
//! A pulse is periodic; what else the sensor feels while it slides (contact load, creep) is
//! slow. Regressing each element on `1, t, (t²), cos hφ(t), sin hφ(t)` (h = 1..3, φ from a
//! [`PulsePhase`]) separates the two with no filter transients at the window's ends, works on
//! any window length (one beat or many) and on unevenly spaced samples (dropped frames), and
//! yields the coefficient covariance exactly: every element shares the design, so the
//! harmonic coefficients of each element have covariance `σ² S⁻¹`, with `S` the Schur
//! complement of the trend in the normal matrix ([`HarmonicFit::information`]).
//!
//! The pulse is the same waveform on every element, scaled by the element's place in the
//! spatial kernel (negative beyond the kernel's zero crossing): the coefficient vectors of
//! all elements are multiples of one waveform vector. [`HarmonicFit::project`] measures each
//! element's multiple of a given waveform (the matched filter), [`shift_waveform`] moves a
//! waveform in time. Nothing here allocates.

use nalgebra::{SMatrix, SVector};

use crate::types::{ELEMENTS, TactileFrame};

/// Harmonics of the pulse rate fitted (the solenoid's square wave has its power in the 1st
/// and 3rd, a physiological pulse in the first three).
pub const HARMONICS: usize = 3;
/// Waveform coefficients: `cos hφ, sin hφ` for h = 1..HARMONICS, in that order.
pub const COEFFS: usize = 2 * HARMONICS;
/// Trend regressors: constant, linear, quadratic.
const TREND: usize = 3;
/// Regressors: the trend, then the waveform coefficients.
const REGRESSORS: usize = TREND + COEFFS;

/// What slow change is fitted beside the harmonics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trend {
    /// A constant and a straight line: for windows of one beat (a parabola over one period
    /// looks too much like the fundamental).
    Linear,
    /// Also a parabola: for windows of several beats at rest, where the creep after a move
    /// is curved.
    Quadratic,
}

/// A waveform as harmonic coefficients (see [`COEFFS`]).
pub type Waveform = SVector<f64, COEFFS>;
/// Information (inverse covariance over σ²) of one element's waveform coefficients.
pub type Information = SMatrix<f64, COEFFS, COEFFS>;

/// The pulse's phase: `φ(t) = 2π (t − t_ref) / period`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulsePhase {
    /// A time at which the phase is zero, s.
    pub t_ref_s: f64,
    pub period_s: f64,
}

impl PulsePhase {
    pub fn phase_rad(&self, t_s: f64) -> f64 {
        std::f64::consts::TAU * (t_s - self.t_ref_s) / self.period_s
    }

    /// Angular rate, rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        std::f64::consts::TAU / self.period_s
    }
}

/// Why a window could not be fitted.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum HarmonicFitError {
    #[error("{samples} samples cannot determine {REGRESSORS} coefficients per element")]
    TooFewSamples { samples: usize },
    #[error("the period {period_s} s is not positive and finite")]
    BadPeriod { period_s: f64 },
    #[error("the samples do not determine the harmonics (too short a window for the period)")]
    Degenerate,
}

/// The fit of one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HarmonicFit {
    /// Each element's waveform coefficients, N.
    pub coeffs: [Waveform; ELEMENTS],
    /// `S`: each element's coefficients have covariance `σ² S⁻¹`.
    pub information: Information,
    /// Residual sum of squares of each element, N².
    pub residual_ss: [f64; ELEMENTS],
    pub samples: usize,
    /// First and last sample time, s.
    pub t_first_s: f64,
    pub t_last_s: f64,
}

/// One element's multiple of a waveform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Each element's amplitude along the waveform, N per unit waveform.
    pub amplitude_n: [f64; ELEMENTS],
    /// Standard error of each amplitude per unit noise SD (multiply by σ).
    pub se_per_sigma: f64,
}

impl HarmonicFit {
    /// Fit the frames `samples` (any order, any spacing) with the given phase. Non-finite
    /// frames are skipped.
    pub fn fit<'a>(
        samples: impl Iterator<Item = &'a TactileFrame> + Clone,
        phase: PulsePhase,
        trend: Trend,
    ) -> Result<Self, HarmonicFitError> {
        if !(phase.period_s.is_finite() && phase.period_s > 0.0 && phase.t_ref_s.is_finite()) {
            return Err(HarmonicFitError::BadPeriod {
                period_s: phase.period_s,
            });
        }
        Self::fit_phase(samples, |t| phase.phase_rad(t), trend)
    }

    /// As [`Self::fit`], with the pulse's phase given at every sample time by `phase_rad`
    /// (a phase warped through each beat's own time, for an irregular heart). The caller
    /// keeps it finite and increasing.
    pub fn fit_phase<'a>(
        samples: impl Iterator<Item = &'a TactileFrame> + Clone,
        phase_rad: impl Fn(f64) -> f64,
        trend: Trend,
    ) -> Result<Self, HarmonicFitError> {
        // The trend regressor runs over [-1, 1] across the window (well conditioned).
        let (mut t_first, mut t_last, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0usize);
        for f in samples.clone().filter(|f| f.is_finite()) {
            t_first = t_first.min(f.t_s);
            t_last = t_last.max(f.t_s);
            n += 1;
        }
        if n < 2 * REGRESSORS {
            return Err(HarmonicFitError::TooFewSamples { samples: n });
        }
        let mid = 0.5 * (t_first + t_last);
        let half = (0.5 * (t_last - t_first)).max(1e-9);
        let mut xtx = SMatrix::<f64, REGRESSORS, REGRESSORS>::zeros();
        let mut xty = SMatrix::<f64, REGRESSORS, ELEMENTS>::zeros();
        let mut yty = [0.0; ELEMENTS];
        for f in samples.filter(|f| f.is_finite()) {
            let x = regressors(f.t_s, mid, half, phase_rad(f.t_s), trend);
            xtx += x * x.transpose();
            for (e, &y) in f.force_n.iter().enumerate() {
                for r in 0..REGRESSORS {
                    xty[(r, e)] += x[r] * y;
                }
                yty[e] += y * y;
            }
        }
        if trend == Trend::Linear {
            // The unused quadratic regressor is identically zero; a unit on its diagonal
            // decouples it (its coefficient solves to zero).
            xtx[(2, 2)] = 1.0;
        }
        let chol = xtx.cholesky().ok_or(HarmonicFitError::Degenerate)?;
        let beta = chol.solve(&xty);
        let mut coeffs = [Waveform::zeros(); ELEMENTS];
        let mut residual_ss = [0.0; ELEMENTS];
        for e in 0..ELEMENTS {
            for k in 0..COEFFS {
                coeffs[e][k] = beta[(TREND + k, e)];
            }
            let explained: f64 = (0..REGRESSORS).map(|r| beta[(r, e)] * xty[(r, e)]).sum();
            residual_ss[e] = (yty[e] - explained).max(0.0);
        }
        // S = A_hh − A_ht A_tt⁻¹ A_th: the information left in the harmonics once the trend
        // is fitted as well.
        let a_tt = xtx.fixed_view::<TREND, TREND>(0, 0).into_owned();
        let a_th = xtx.fixed_view::<TREND, COEFFS>(0, TREND).into_owned();
        let a_hh = xtx.fixed_view::<COEFFS, COEFFS>(TREND, TREND).into_owned();
        let a_tt_inv = a_tt.try_inverse().ok_or(HarmonicFitError::Degenerate)?;
        let information = a_hh - a_th.transpose() * a_tt_inv * a_th;
        let information = 0.5 * (information + information.transpose());
        if information.cholesky().is_none() {
            return Err(HarmonicFitError::Degenerate);
        }
        Ok(Self {
            coeffs,
            information,
            residual_ss,
            samples: n,
            t_first_s: t_first,
            t_last_s: t_last,
        })
    }

    /// Each element's amplitude along `waveform` (generalized least squares with the
    /// coefficient covariance): the matched filter for that waveform. `None` if the
    /// waveform carries no information in this window.
    pub fn project(&self, waveform: &Waveform) -> Option<Projection> {
        let sq = self.information * waveform;
        let norm = waveform.dot(&sq);
        if !(norm.is_finite() && norm > 0.0) {
            return None;
        }
        let mut amplitude_n = [0.0; ELEMENTS];
        for (a, c) in amplitude_n.iter_mut().zip(&self.coeffs) {
            *a = c.dot(&sq) / norm;
        }
        Some(Projection {
            amplitude_n,
            se_per_sigma: 1.0 / norm.sqrt(),
        })
    }

    /// The coefficients of a weighted sum of elements, `Σ w_e c_e`.
    pub fn combine(&self, weights: &[f64; ELEMENTS]) -> Waveform {
        self.coeffs
            .iter()
            .zip(weights)
            .fold(Waveform::zeros(), |acc, (c, w)| acc + c * *w)
    }

    /// Window length, s.
    pub fn span_s(&self) -> f64 {
        self.t_last_s - self.t_first_s
    }
}

fn regressors(t: f64, mid: f64, half: f64, phi: f64, trend: Trend) -> SVector<f64, REGRESSORS> {
    let mut x = SVector::<f64, REGRESSORS>::zeros();
    let u = (t - mid) / half;
    x[0] = 1.0;
    x[1] = u;
    if trend == Trend::Quadratic {
        x[2] = u * u - 1.0 / 3.0;
    }
    let (s1, c1) = phi.sin_cos();
    // cos hφ, sin hφ by the angle-addition recurrence.
    let (mut c, mut s) = (c1, s1);
    for h in 0..HARMONICS {
        x[TREND + 2 * h] = c;
        x[TREND + 1 + 2 * h] = s;
        let next_c = c * c1 - s * s1;
        let next_s = s * c1 + c * s1;
        c = next_c;
        s = next_s;
    }
    x
}

/// The waveform `w` delayed by `delay_rad` of the fundamental's phase: if `w` describes
/// `f(φ)`, the result describes `f(φ − delay_rad)`.
pub fn shift_waveform(w: &Waveform, delay_rad: f64) -> Waveform {
    let mut out = Waveform::zeros();
    for h in 0..HARMONICS {
        let (s, c) = ((h + 1) as f64 * delay_rad).sin_cos();
        let (a, b) = (w[2 * h], w[2 * h + 1]);
        // a cos h(φ−δ) + b sin h(φ−δ) = (a cos hδ − b sin hδ) cos hφ + (a sin hδ + b cos hδ) sin hφ
        out[2 * h] = a * c - b * s;
        out[2 * h + 1] = a * s + b * c;
    }
    out
}

/// The phase of a waveform's fundamental: the delay that [`shift_waveform`] would remove to
/// make its fundamental a pure cosine (peak at φ = 0).
pub fn fundamental_delay_rad(w: &Waveform) -> f64 {
    w[1].atan2(w[0])
}

/// Evaluate a waveform at phase `phi`.
pub fn waveform_value(w: &Waveform, phi: f64) -> f64 {
    (0..HARMONICS)
        .map(|h| {
            let (s, c) = ((h + 1) as f64 * phi).sin_cos();
            w[2 * h] * c + w[2 * h + 1] * s
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn frames(n: usize, dt: f64, f: impl Fn(f64, usize) -> f64) -> Vec<TactileFrame> {
        (0..n)
            .map(|i| {
                let t = 3.0 + i as f64 * dt;
                TactileFrame {
                    t_s: t,
                    seq: i as u64,
                    force_n: std::array::from_fn(|e| f(t, e)),
                }
            })
            .collect()
    }

    #[test]
    fn recovers_harmonics_under_a_trend() {
        let phase = PulsePhase {
            t_ref_s: 0.3,
            period_s: 0.9,
        };
        let fs = frames(120, 0.01, |t, e| {
            let phi = phase.phase_rad(t);
            let k = e as f64 - 4.0;
            0.5 + 0.2 * t - 0.05 * t * t
                + k * (0.03 * phi.cos() - 0.01 * (2.0 * phi).sin() + 0.004 * (3.0 * phi).cos())
        });
        let fit = HarmonicFit::fit(fs.iter(), phase, Trend::Quadratic).expect("fits");
        for e in 0..ELEMENTS {
            let k = e as f64 - 4.0;
            let want = [0.03 * k, 0.0, 0.0, -0.01 * k, 0.004 * k, 0.0];
            for (c, w) in fit.coeffs[e].iter().zip(want) {
                assert!((c - w).abs() < 1e-9, "element {e}: {c} vs {w}");
            }
            assert!(fit.residual_ss[e] < 1e-12);
        }
        // Projection onto the true waveform gives each element's multiple.
        let w = Waveform::from_column_slice(&[0.03, 0.0, 0.0, -0.01, 0.004, 0.0]);
        let p = fit.project(&w).expect("informative");
        for e in 0..ELEMENTS {
            assert!((p.amplitude_n[e] - (e as f64 - 4.0)).abs() < 1e-8);
        }
    }

    #[test]
    fn a_warped_phase_recovers_beats_of_changing_length() {
        // Beats 0.8, 1.1 and 0.7 s long: one period of the waveform each.
        let knots = [(3.0, 0.0), (3.8, TAU), (4.9, 2.0 * TAU), (5.6, 3.0 * TAU)];
        let warped = |t: f64| {
            let i = knots
                .partition_point(|k| k.0 <= t)
                .clamp(1, knots.len() - 1);
            let (p, q) = (knots[i - 1], knots[i]);
            p.1 + (q.1 - p.1) * (t - p.0) / (q.0 - p.0)
        };
        let fs = frames(260, 0.01, |t, e| {
            let phi = warped(t);
            (e as f64 - 4.0) * (0.02 * phi.cos() + 0.01 * (2.0 * phi).sin()) + 0.3 - 0.1 * t
        });
        let fit = HarmonicFit::fit_phase(fs.iter(), warped, Trend::Linear).expect("fits");
        let w = Waveform::from_column_slice(&[0.02, 0.0, 0.0, 0.01, 0.0, 0.0]);
        let p = fit.project(&w).expect("informative");
        for e in 0..ELEMENTS {
            assert!((p.amplitude_n[e] - (e as f64 - 4.0)).abs() < 1e-8);
        }
        // The same samples at one mean period lose much of the waveform.
        let mean = PulsePhase {
            t_ref_s: 3.0,
            period_s: 2.6 / 3.0,
        };
        let plain = HarmonicFit::fit(fs.iter(), mean, Trend::Linear).expect("fits");
        let q = plain.project(&w).expect("informative");
        assert!(q.amplitude_n[0].abs() < 0.8 * 4.0, "{}", q.amplitude_n[0]);
    }

    #[test]
    fn flat_and_short_windows() {
        let phase = PulsePhase {
            t_ref_s: 0.0,
            period_s: 1.0,
        };
        let flat = frames(100, 0.01, |_, _| 0.2);
        let fit = HarmonicFit::fit(flat.iter(), phase, Trend::Linear).expect("a flat window fits");
        assert!(fit.coeffs.iter().all(|c| c.norm() < 1e-12));
        let short = frames(10, 0.01, |_, _| 0.2);
        assert!(matches!(
            HarmonicFit::fit(short.iter(), phase, Trend::Quadratic),
            Err(HarmonicFitError::TooFewSamples { .. })
        ));
        // All samples at one instant determine nothing.
        let mut same = frames(40, 0.01, |_, _| 0.2);
        for f in &mut same {
            f.t_s = 1.0;
        }
        assert_eq!(
            HarmonicFit::fit(same.iter(), phase, Trend::Linear),
            Err(HarmonicFitError::Degenerate)
        );
        let bad = PulsePhase {
            t_ref_s: 0.0,
            period_s: 0.0,
        };
        assert!(matches!(
            HarmonicFit::fit(flat.iter(), bad, Trend::Linear),
            Err(HarmonicFitError::BadPeriod { .. })
        ));
        // Non-finite frames are skipped, not propagated.
        let mut holes = frames(100, 0.01, |t, _| (phase.phase_rad(t)).cos());
        holes[17].force_n[3] = f64::NAN;
        let fit = HarmonicFit::fit(holes.iter(), phase, Trend::Linear).expect("fits");
        assert_eq!(fit.samples, 99);
        assert!((fit.coeffs[3][0] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn standard_error_matches_white_noise() {
        // Deterministic pseudo-noise: the scatter of the amplitude over many windows matches
        // se_per_sigma × σ.
        let phase = PulsePhase {
            t_ref_s: 0.0,
            period_s: 1.0,
        };
        let w = Waveform::from_column_slice(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let mut state = 12345u64;
        let mut normal = move || {
            // Box–Muller on a xorshift.
            let mut u = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (u().max(1e-300), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let mut sq = 0.0;
        let mut se = 0.0;
        let runs = 400;
        for _ in 0..runs {
            let fs: Vec<TactileFrame> = frames(100, 0.01, |_, _| 0.0)
                .into_iter()
                .map(|mut f| {
                    f.force_n = std::array::from_fn(|_| 0.012 * normal());
                    f
                })
                .collect();
            let fit = HarmonicFit::fit(fs.iter(), phase, Trend::Linear).expect("fits");
            let p = fit.project(&w).expect("informative");
            sq += p.amplitude_n.iter().map(|a| a * a).sum::<f64>();
            se = p.se_per_sigma * 0.012;
        }
        let rms = (sq / (runs * ELEMENTS) as f64).sqrt();
        assert!(
            (rms / se - 1.0).abs() < 0.1,
            "scatter {rms} vs predicted {se}"
        );
        // One beat at 100 Hz: about σ √(2/N).
        assert!(
            (se - 0.012 * (2.0f64 / 100.0).sqrt()).abs() < 0.2 * se,
            "{se}"
        );
    }

    #[test]
    fn shifting_a_waveform_delays_it() {
        let w = Waveform::from_column_slice(&[0.3, 0.1, -0.2, 0.05, 0.02, -0.07]);
        for delay in [-2.0, -0.3, 0.0, 0.7, 3.0] {
            let shifted = shift_waveform(&w, delay);
            for k in 0..20 {
                let phi = k as f64 * 0.31;
                let a = waveform_value(&shifted, phi);
                let b = waveform_value(&w, phi - delay);
                assert!((a - b).abs() < 1e-12);
            }
        }
        let aligned = shift_waveform(&w, -fundamental_delay_rad(&w));
        assert!(aligned[1].abs() < 1e-12 && aligned[0] > 0.0);
        assert!(fundamental_delay_rad(&aligned).abs() < 1e-12);
    }
}
