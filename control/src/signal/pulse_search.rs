//! Finding a pulse of unknown rate in a window taken at rest: a search over the period for
//! the strongest common periodic waveform across the ten elements.
//!
//! At each trial period the window is fitted by [`HarmonicFit`] (with a quadratic trend: the
//! creep after a move is curved). Under noise alone each element's harmonic coefficients,
//! whitened by the information matrix, are independent `N(0, σ²)`; a pulse adds the same
//! waveform to every element, scaled by the spatial kernel: a rank-one pattern, `k qᵀ`. A
//! heart does not keep its phase for long (beat-to-beat intervals vary by a few per cent),
//! so a long window is cut into sub-windows of about `coherent_s`, each fitted with its own
//! phase; what they share is the spatial pattern `k`. The statistic is the largest
//! eigenvalue of the elements' 10 × 10 scatter of whitened coefficients summed over the
//! sub-windows, over `σ²` (all elements pooled, signs and all: the out-of-phase elements add
//! to it), centred and scaled by its noise-only (Tracy–Widom) law so that one threshold
//! serves every window length, and maximized over the period. A static lump or a drift is
//! not periodic and does not raise it: this is the pulsatility test. The threshold is set
//! on noise-only windows (docs/tracker-beatslide.md gives the measured false-alarm rates).
//!
//! Periods are searched only up to the window's length over `min_cycles`: over fewer
//! cycles the harmonics of a long period and the trend are nearly collinear, and the
//! curvature of a creep after a move passes for a slow pulse.
//!
//! For speed the search runs on block means of `decimation` samples (the pulse's third
//! harmonic stays below their Nyquist rate); the final fit at the best period uses every
//! sample. The period grid is fine enough that the phase drifts by under a tenth of a cycle
//! across a sub-window between grid points, refined by a parabola. Buffers are allocated at
//! construction.

use nalgebra::{SMatrix, SVector, SymmetricEigen};

use super::beat_interval::{self, BeatIntervals};
use super::harmonic::{
    COEFFS, HarmonicFit, Projection, PulsePhase, Trend, Waveform, fundamental_delay_rad,
    shift_waveform,
};
use crate::types::{ELEMENTS, TactileFrame};

/// Settings of the search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseSearchSettings {
    /// Periods searched, s.
    pub min_period_s: f64,
    pub max_period_s: f64,
    /// Declared a pulse when the statistic (the normalized largest eigenvalue, see
    /// [`normalized`]) exceeds this.
    pub threshold: f64,
    /// Samples averaged per block in the search.
    pub decimation: usize,
    /// Whole cycles the window must hold: periods longer than the window over this are
    /// not searched (over fewer cycles a slow creep looks like a slow pulse).
    pub min_cycles: f64,
    /// Longest stretch over which the pulse is taken to keep its phase, s: longer windows
    /// are cut into sub-windows of about this length, fitted each with its own phase, and
    /// pooled through their common spatial pattern (a heart's rate wanders).
    pub coherent_s: f64,
    /// The heart's plausible periods, s: the beat-interval check ([`beat_interval`]) looks
    /// here whatever `min_period_s..max_period_s` is, so that a search narrowed around a
    /// wrong period (twice the heart's) can still return the heart's.
    pub plausible_min_period_s: f64,
    pub plausible_max_period_s: f64,
}

/// A pulse found in a window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseFound {
    /// Its phase: `t_ref_s` is a time at which the waveform's fundamental peaks.
    pub phase: PulsePhase,
    /// The waveform (unit norm, fundamental a pure cosine), signed so that the element with
    /// the largest amplitude is positive.
    pub waveform: Waveform,
    /// Each element's amplitude along the waveform, N, with its standard error per unit σ.
    pub amplitudes: Projection,
    /// The detection statistic and the threshold it passed.
    pub statistic: f64,
    pub noise_sd_n: f64,
}

impl PulseFound {
    /// The same pulse with the opposite sign: every amplitude negated, the waveform
    /// negated and delayed half a period so that its fundamental stays a pure cosine.
    /// (A square wave's sign and its half-period shift cannot be told apart in time; the
    /// spatial kernel tells them apart.)
    pub fn flipped(&self) -> Self {
        let mut out = *self;
        out.waveform = shift_waveform(&-self.waveform, -std::f64::consts::PI);
        out.phase.t_ref_s += 0.5 * self.phase.period_s;
        for a in &mut out.amplitudes.amplitude_n {
            *a = -*a;
        }
        out
    }
}

/// Why no pulse was found.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SearchMiss {
    #[error("the window is too short for the longest period searched")]
    TooShort,
    #[error("the period range {min_s} to {max_s} s is empty or not finite")]
    BadRange { min_s: f64, max_s: f64 },
    #[error("the noise SD {0} N is not positive and finite")]
    BadNoise(f64),
    #[error(
        "no periodic pattern: statistic {statistic:.1} at {period_s:.3} s is below {threshold:.1}"
    )]
    BelowThreshold {
        statistic: f64,
        period_s: f64,
        threshold: f64,
    },
}

/// The search with its buffers.
#[derive(Debug, Clone)]
pub struct PulseSearch {
    blocks: Vec<TactileFrame>,
    /// The blocks combined with the pulse's spatial pattern.
    combined: Vec<f64>,
    /// The beat intervals of the windows searched so far (see [`PulseSearch::search`]).
    beats: BeatIntervals,
}

/// A longer period than the harmonic search's is taken from the beat intervals only if
/// its harmonic statistic is this many times higher: a period of half the heart's misses
/// the fundamental (a pulse whose second harmonic is 1.3 times its fundamental scores
/// about 1.6 times higher at its true period), while two beats of an irregular heart
/// score about as well as one.
const LONGER_PERIOD_GAIN: f64 = 1.3;

/// Weight of the earlier windows' beat intervals when a new window is pooled.
const BEATS_RETAIN: f64 = 0.5;

/// Most lags the beat-interval check evaluates (2.2 s at 100 Hz undecimated fits).
const MAX_LAGS: usize = 512;

impl PulseSearch {
    /// A search for windows of up to `max_frames` frames.
    pub fn new(max_frames: usize) -> Self {
        let n = max_frames.max(1);
        Self {
            blocks: Vec::with_capacity(n),
            combined: vec![0.0; n],
            beats: BeatIntervals::new(n, MAX_LAGS),
        }
    }

    /// Forget the beat intervals pooled from earlier searches (another heart).
    pub fn forget_beats(&mut self) {
        self.beats.forget();
    }

    /// Search the frames (time order) for a pulse; `noise_sd_n` is one element's noise SD.
    /// The period is checked against the beat intervals of this window pooled with those
    /// of the earlier searches (the same heart; [`PulseSearch::forget_beats`] to start
    /// afresh).
    pub fn search<'a>(
        &mut self,
        frames: impl Iterator<Item = &'a TactileFrame> + Clone,
        noise_sd_n: f64,
        settings: &PulseSearchSettings,
    ) -> Result<PulseFound, SearchMiss> {
        let (lo, hi) = (settings.min_period_s, settings.max_period_s);
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo < hi) {
            return Err(SearchMiss::BadRange {
                min_s: lo,
                max_s: hi,
            });
        }
        if !(noise_sd_n.is_finite() && noise_sd_n > 0.0) {
            return Err(SearchMiss::BadNoise(noise_sd_n));
        }
        let d = settings.decimation.max(1);
        self.decimate(frames.clone(), d);
        let (Some(first), Some(last)) = (self.blocks.first(), self.blocks.last()) else {
            return Err(SearchMiss::TooShort);
        };
        let (t0, span) = (first.t_s, last.t_s - first.t_s);
        // Sub-windows short enough for the heart to keep its phase within each.
        let (m, sub_span) = sub_windows(span, settings.coherent_s);
        // The longest period the window holds enough cycles of.
        let window_hi = sub_span / settings.min_cycles.max(1.0);
        let hi = hi.min(window_hi);
        if hi.is_nan() || hi <= lo {
            return Err(SearchMiss::TooShort);
        }
        let bounds = Bounds { t0, sub_span, m };
        let block_var = noise_sd_n * noise_sd_n / d as f64;
        // Frequency grid: a tenth of a cycle of drift across a sub-window per step.
        let (f_lo, f_hi) = (1.0 / hi, 1.0 / lo);
        let df = GRID_CYCLES / sub_span;
        let blocks = &self.blocks;
        let stat_at = |f: f64| -> f64 {
            spatial_scatter(blocks.iter(), &bounds, f)
                .and_then(|(scatter, dof)| {
                    leading_eigen(&scatter).map(|(l, _)| normalized(l / block_var, dof))
                })
                .unwrap_or(f64::NEG_INFINITY)
        };
        let (statistic, f_best) = argmax(&stat_at, f_lo, f_hi, df);
        if statistic.is_nan() || statistic <= settings.threshold {
            return Err(SearchMiss::BelowThreshold {
                statistic,
                period_s: 1.0 / f_best,
                threshold: settings.threshold,
            });
        }
        // The beat-interval check: where the beats' autocorrelation puts the period
        // elsewhere, the harmonic search is repeated around it for precision. A shorter
        // period is taken on the autocorrelation's word, even outside the range searched
        // (it already preferred the shortest well-supported peak; a search narrowed
        // around a clock at half the heart's rate must be able to leave it). A longer one
        // needs more: a few irregular beats can lift the correlation at two beats, and
        // the harmonics of two beats fit an irregular pulse about as well as those of
        // one (measured: in the fast-irregular-heart family, searches narrowed around the
        // right period moved to twice it). So it must lie within the range searched and
        // the harmonics must fit it clearly better ([`LONGER_PERIOD_GAIN`]), as they do
        // when the shorter period was half the heart's (its harmonics miss the
        // fundamental).
        let f_best = match self.beat_period(&bounds, f_best, window_hi, settings) {
            Some(p) if !beat_interval::agree(p, 1.0 / f_best) => {
                let longer = p > 1.0 / f_best;
                let (p_lo, p_hi) = (
                    (p / (1.0 + beat_interval::TOLERANCE)).max(settings.plausible_min_period_s),
                    (p * (1.0 + beat_interval::TOLERANCE)).min(if longer {
                        hi
                    } else {
                        window_hi.max(p)
                    }),
                );
                if p_lo < p_hi {
                    let stat_at = |f: f64| -> f64 {
                        spatial_scatter(self.blocks.iter(), &bounds, f)
                            .and_then(|(scatter, dof)| {
                                leading_eigen(&scatter).map(|(l, _)| normalized(l / block_var, dof))
                            })
                            .unwrap_or(f64::NEG_INFINITY)
                    };
                    let (stat, f) = argmax(&stat_at, 1.0 / p_hi, 1.0 / p_lo, df);
                    if !longer || stat > LONGER_PERIOD_GAIN * statistic {
                        f
                    } else {
                        f_best
                    }
                } else {
                    f_best
                }
            }
            _ => f_best,
        };
        self.describe(frames, &bounds, f_best, statistic, noise_sd_n)
    }

    /// The beat period by the autocorrelation of the blocks combined with the spatial
    /// pattern at `f`, over the plausible periods up to `hi` (the longest the window
    /// holds enough cycles of); `None` when the beats do not correlate clearly.
    fn beat_period(
        &mut self,
        bounds: &Bounds,
        f: f64,
        hi: f64,
        settings: &PulseSearchSettings,
    ) -> Option<f64> {
        let (scatter, _) = spatial_scatter(self.blocks.iter(), bounds, f)?;
        let (_, pattern) = leading_eigen(&scatter)?;
        let n = self.blocks.len().min(self.combined.len());
        for (y, b) in self.combined.iter_mut().zip(&self.blocks) {
            *y = (0..ELEMENTS).map(|e| pattern[e] * b.force_n[e]).sum();
        }
        let (first, last) = (self.blocks.first()?, self.blocks.last()?);
        let dt = (last.t_s - first.t_s) / (n.max(2) - 1) as f64;
        let (lo, hi) = (
            settings.plausible_min_period_s,
            settings.plausible_max_period_s.min(hi),
        );
        if !self
            .beats
            .add(&self.combined[..n], dt, lo, hi, BEATS_RETAIN)
        {
            return None;
        }
        let acf = self.beats.autocorrelation(lo, hi)?;
        acf.beat_period().map(|b| b.period_s)
    }

    /// The pulse at frequency `f`: its spatial pattern from all sub-windows, each
    /// element's amplitude averaged over them (each sub-window with its own phase), and
    /// the phase and waveform of the last sub-window (the most recent) for the beat clock.
    fn describe<'a>(
        &self,
        frames: impl Iterator<Item = &'a TactileFrame> + Clone,
        bounds: &Bounds,
        f: f64,
        statistic: f64,
        noise_sd_n: f64,
    ) -> Result<PulseFound, SearchMiss> {
        let (scatter, _) =
            spatial_scatter(frames.clone(), bounds, f).ok_or(SearchMiss::TooShort)?;
        let (_, pattern) = leading_eigen(&scatter).ok_or(SearchMiss::TooShort)?;
        let phase = PulsePhase {
            t_ref_s: bounds.t0,
            period_s: 1.0 / f,
        };
        let mut sum = [0.0; ELEMENTS];
        let mut var_sum = 0.0;
        let mut last: Option<Waveform> = None;
        for j in 0..bounds.m {
            let fit = bounds
                .fit(frames.clone(), j, phase)
                .ok_or(SearchMiss::TooShort)?;
            let w: [f64; ELEMENTS] = std::array::from_fn(|e| pattern[e]);
            let q = fit.combine(&w);
            let Some(p) = fit.project(&q) else {
                continue;
            };
            // Scale each sub-window's amplitudes to a unit waveform.
            let norm = q.norm();
            for (s, a) in sum.iter_mut().zip(&p.amplitude_n) {
                *s += a * norm;
            }
            var_sum += (p.se_per_sigma * norm).powi(2);
            last = Some(q);
        }
        let mut waveform = last.ok_or(SearchMiss::TooShort)?;
        let norm = waveform.norm();
        if norm.is_nan() || norm <= 0.0 {
            return Err(SearchMiss::TooShort);
        }
        waveform /= norm;
        let m = bounds.m as f64;
        let mut amplitudes = Projection {
            amplitude_n: sum.map(|s| s / m),
            se_per_sigma: var_sum.sqrt() / m,
        };
        let strongest = amplitudes
            .amplitude_n
            .iter()
            .copied()
            .max_by(|a, b| a.abs().total_cmp(&b.abs()))
            .unwrap_or(0.0);
        if strongest < 0.0 {
            waveform = -waveform;
            for a in &mut amplitudes.amplitude_n {
                *a = -*a;
            }
        }
        // The fundamental a pure cosine: the clock's phase reference.
        let delay = fundamental_delay_rad(&waveform);
        let waveform = shift_waveform(&waveform, -delay);
        let phase = PulsePhase {
            t_ref_s: phase.t_ref_s + delay / phase.omega_rad_s(),
            period_s: phase.period_s,
        };
        Ok(PulseFound {
            phase,
            waveform,
            amplitudes,
            statistic,
            noise_sd_n,
        })
    }

    /// Block means of `d` consecutive frames (a block closes early at a sequence gap).
    fn decimate<'a>(&mut self, frames: impl Iterator<Item = &'a TactileFrame>, d: usize) {
        self.blocks.clear();
        let room = self.blocks.capacity();
        let mut acc = TactileFrame {
            t_s: 0.0,
            seq: 0,
            force_n: [0.0; ELEMENTS],
        };
        let mut count = 0usize;
        let mut last_seq: Option<u64> = None;
        let flush = |acc: &mut TactileFrame, count: &mut usize, out: &mut Vec<TactileFrame>| {
            if *count == d && out.len() < room {
                let k = *count as f64;
                out.push(TactileFrame {
                    t_s: acc.t_s / k,
                    seq: out.len() as u64,
                    force_n: std::array::from_fn(|e| acc.force_n[e] / k),
                });
            }
            *acc = TactileFrame {
                t_s: 0.0,
                seq: 0,
                force_n: [0.0; ELEMENTS],
            };
            *count = 0;
        };
        for f in frames.filter(|f| f.is_finite()) {
            if let Some(s) = last_seq
                && s.checked_add(1) != Some(f.seq)
            {
                flush(&mut acc, &mut count, &mut self.blocks);
            }
            last_seq = Some(f.seq);
            acc.t_s += f.t_s;
            for e in 0..ELEMENTS {
                acc.force_n[e] += f.force_n[e];
            }
            count += 1;
            if count == d {
                flush(&mut acc, &mut count, &mut self.blocks);
            }
        }
    }
}

/// The frequency in `f_lo..=f_hi` (grid step about `df`, refined by a parabola between
/// the grid neighbours) where `stat_at` is largest, and that largest value.
fn argmax(stat_at: &impl Fn(f64) -> f64, f_lo: f64, f_hi: f64, df: f64) -> (f64, f64) {
    let n = ((f_hi - f_lo) / df).ceil().max(1.0) as usize;
    let freq = |i: usize| f_lo + (f_hi - f_lo) * i as f64 / n as f64;
    let mut best = (f64::NEG_INFINITY, 0usize);
    for i in 0..=n {
        let s = stat_at(freq(i));
        if s > best.0 {
            best = (s, i);
        }
    }
    let (stat, i) = best;
    let mut f_best = freq(i);
    if i > 0 && i < n {
        let below = stat_at(freq(i - 1));
        let above = stat_at(freq(i + 1));
        let denom = below - 2.0 * stat + above;
        if denom < 0.0 {
            let shift = (0.5 * (below - above) / denom).clamp(-0.5, 0.5);
            f_best += shift * (f_hi - f_lo) / n as f64;
        }
    }
    (stat.max(stat_at(f_best)), f_best)
}

/// Most sub-windows a search splits a window into.
const MAX_SUBWINDOWS: usize = 64;

/// The search's frequency step, in cycles over a sub-window.
pub const GRID_CYCLES: f64 = 0.1;

/// How many sub-windows a window of `span_s` is cut into for a coherent stretch of
/// `coherent_s` (any non-positive or non-finite value: one), and their length, s.
fn sub_windows(span_s: f64, coherent_s: f64) -> (usize, f64) {
    let coherent = if coherent_s.is_finite() && coherent_s > 0.0 {
        coherent_s
    } else {
        f64::INFINITY
    };
    let m = ((span_s / coherent).floor() as usize).clamp(1, MAX_SUBWINDOWS);
    (m, span_s / m as f64)
}

/// The search's frequency resolution over a window of `span_s`, Hz: one cycle over a
/// sub-window, about the width of a pulse's peak in the statistic.
pub fn resolution_hz(span_s: f64, settings: &PulseSearchSettings) -> f64 {
    1.0 / sub_windows(span_s, settings.coherent_s).1
}

/// A window cut into `m` equal sub-windows from `t0`.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    t0: f64,
    sub_span: f64,
    m: usize,
}

impl Bounds {
    fn contains(&self, j: usize, t: f64) -> bool {
        let lo = self.t0 + j as f64 * self.sub_span;
        let hi = lo + self.sub_span;
        // The last sub-window keeps its end sample.
        t >= lo && (t < hi || (j + 1 == self.m && t <= hi + 1e-9))
    }

    fn fit<'a>(
        &self,
        frames: impl Iterator<Item = &'a TactileFrame> + Clone,
        j: usize,
        phase: PulsePhase,
    ) -> Option<HarmonicFit> {
        HarmonicFit::fit(
            frames.filter(move |f| self.contains(j, f.t_s)),
            phase,
            Trend::Quadratic,
        )
        .ok()
    }
}

/// `Σ_j C_j S_j C_jᵀ` over the sub-windows at frequency `f`: the elements' covariance of
/// whitened harmonic coefficients (noise alone: σ² times the identity times the degrees
/// of freedom), and those degrees of freedom.
fn spatial_scatter<'a>(
    frames: impl Iterator<Item = &'a TactileFrame> + Clone,
    bounds: &Bounds,
    f: f64,
) -> Option<(SMatrix<f64, ELEMENTS, ELEMENTS>, usize)> {
    let phase = PulsePhase {
        t_ref_s: bounds.t0,
        period_s: 1.0 / f,
    };
    let mut scatter = SMatrix::<f64, ELEMENTS, ELEMENTS>::zeros();
    let mut dof = 0;
    for j in 0..bounds.m {
        let fit = bounds.fit(frames.clone(), j, phase)?;
        let mut c = SMatrix::<f64, ELEMENTS, COEFFS>::zeros();
        for e in 0..ELEMENTS {
            c.set_row(e, &fit.coeffs[e].transpose());
        }
        scatter += c * fit.information * c.transpose();
        dof += COEFFS;
    }
    Some((scatter, dof))
}

/// Largest eigenvalue of a symmetric matrix and its unit eigenvector.
fn leading_eigen(m: &SMatrix<f64, ELEMENTS, ELEMENTS>) -> Option<(f64, SVector<f64, ELEMENTS>)> {
    let eig = SymmetricEigen::new(*m);
    let (k, &lambda) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    lambda
        .is_finite()
        .then(|| (lambda, eig.eigenvectors.column(k).into_owned()))
}

/// The largest eigenvalue of a white-noise Wishart matrix (`ELEMENTS` × `dof`, unit
/// variance) centred and scaled by its Tracy–Widom approximation (Johnstone 2001): about
/// −1.2 ± 1.3 for noise alone, whatever the number of sub-windows.
pub fn normalized(lambda: f64, dof: usize) -> f64 {
    let n = dof as f64 - 0.5;
    let p = ELEMENTS as f64 - 0.5;
    let mu = (n.sqrt() + p.sqrt()).powi(2);
    let scale = mu.sqrt() * (1.0 / n.sqrt() + 1.0 / p.sqrt()).cbrt();
    (lambda - mu) / scale
}
