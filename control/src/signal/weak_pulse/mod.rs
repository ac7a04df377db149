//! Feeling a pulse far below the tactile array's noise (issue 18): a streaming likelihood
//! ratio test over the artery's position on the array and the pulse's timing, fed one frame
//! at a time, deciding "found" (with the position and its standard error) or "not found by
//! the limit".
//!
//! The chain, one idea per file:
//! - [`detrend`]: each element's static load and slow drift out (a lump or tissue drift has
//!   nothing periodic left to offer), and its noise SD measured from the data;
//! - [`fold`]: a segment's samples (10 s by default) folded at every trial heart rate and
//!   matched with the temporal template ([`waveform`]: a generic arterial pressure pulse,
//!   or a learned one) at every phase;
//! - the spatial template: the kernel family (`kernel_fit::element_kernel`) at positions
//!   across and one margin beyond the array, each element whitened by its noise;
//! - [`track`]: the heart's rate and phase followed from segment to segment with its
//!   beat-to-beat variability as a prior, and the likelihood ratio averaged over tracks,
//!   amplitudes and positions (why averaged, and why segments, is said there);
//! - [`noise_law`]: the statistic's noise-only law measured by Monte Carlo on the detector
//!   itself, and the threshold for a false-alarm rate over a window of a given length;
//! - [`locate`]: the position fitted along the pulse's track, with its Cramér-Rao SE.
//!
//! Measured (detector_tests, pfa 0.05, heart rates 0.6-2.5 Hz, beat intervals varying by
//! 4.6 %, 10 s segments): a pulse the position-searched bound feels in 5 beats is found
//! every time, in 17.5 beats on average (3.5x: no decision comes before the first segment's
//! end, 12 beats at this heart), placed within 1 mm in 87 % at the decision (RMS 3.1x the
//! Cramér-Rao bound; `WeakPulseDetector::keep_weighing` refines it). On IMA-like simulated
//! marks (sim-backend's `weak_marks`, pfa 0.01 within 600 s) it finds 60-70 % of the marks,
//! at a median of 3.8-4.1x the bound's beats (docs/BENCHMARKS.md). The gap is the timing
//! search: the unknown rate and phase (about 2500 states) and the track's diffusion between
//! segments cost more evidence than the bound's margin at a per-beat SNR near 1.
//!
//! Memory is fixed at construction (folds, track states, a 2 s ring): nothing grows with
//! the window. Frames arriving after a decision are ignored.

mod detrend;
mod fold;
mod locate;
pub mod noise_law;
mod noise_table;
mod track;
pub mod waveform;

pub use noise_law::{NoiseLaw, Threshold};
pub use waveform::{PulseShape, generic_pressure};

use crate::sensor::ArrayGeometry;
use crate::types::{ELEMENTS, TactileFrame};
use detrend::Detrend;
use fold::Folds;
use locate::SpatialKernel;
use track::{Track, TrackSettings};

/// What the detector searches and how long it may take.
#[derive(Debug, Clone, PartialEq)]
pub struct WeakPulseSettings {
    /// Pitch, element direction and frame rate (its noise SD is not used: the detector
    /// measures each element's).
    pub geometry: ArrayGeometry,
    /// Width of the spatial kernel (`element_kernel`), m: the artery's depth.
    pub kernel_width_m: f64,
    /// Step of the searched artery positions, m, and how far beyond the outer elements.
    pub position_step_m: f64,
    pub margin_m: f64,
    /// The heart rates searched, Hz.
    pub min_rate_hz: f64,
    pub max_rate_hz: f64,
    /// The coherent segment, s: the pulse is taken to keep its rate and phase within one.
    /// 10 s by default, chosen on IMA-like marks (seeds 1 and 2 of `weak_marks`): 3, 6, 10
    /// and 15 s found 16, 28, 36, 38 of 60 and 22, -, 42, 45 of 60 (docs/BENCHMARKS.md);
    /// 15 s gained little for half again the cost of a segment's end and a longer wait to
    /// any decision. An irregular heart (10-20 % interval SD) defeats every length alike.
    pub segment_s: f64,
    /// Phase bins of a fold.
    pub phase_bins: usize,
    /// Beat-to-beat variability of the heart's interval (SD over the mean) the track allows.
    pub beat_interval_cv: f64,
    /// Probability that the rate steps to a neighbouring trial rate between segments (each way).
    pub rate_step_probability: f64,
    /// Length of the moving average taken out of each element, s.
    pub detrend_s: f64,
    /// The pulse amplitudes averaged over, as the SNR one second of pulse gives.
    pub snr_per_root_s: [f64; 3],
    /// The longest window, s (the noise law is measured up to it).
    pub limit_s: f64,
}

impl Default for WeakPulseSettings {
    fn default() -> Self {
        let geometry = ArrayGeometry::default();
        Self {
            geometry,
            kernel_width_m: 0.005,
            position_step_m: geometry.pitch_m,
            margin_m: geometry.pitch_m,
            min_rate_hz: 0.6,
            max_rate_hz: 2.5,
            segment_s: 10.0,
            phase_bins: 20,
            beat_interval_cv: 0.02,
            rate_step_probability: 0.05,
            detrend_s: 2.0,
            snr_per_root_s: [0.35, 0.7, 1.4],
            limit_s: 180.0,
        }
    }
}

/// The false-alarm rates (over a window) the shipped threshold table holds.
pub const TABLE_PFAS: [f64; 2] = [0.01, 0.05];

impl WeakPulseSettings {
    /// The settings of the shipped threshold table (`noise_table`): the defaults with a
    /// 600 s limit (the longest window a mark may wait).
    pub fn tabulated() -> Self {
        Self {
            limit_s: 600.0,
            ..Self::default()
        }
    }

    fn check(&self) -> Result<(), WeakPulseError> {
        self.geometry.check().map_err(WeakPulseError::Geometry)?;
        let positive = |what: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(WeakPulseError::Setting {
                    what,
                    rule: "positive and finite",
                    value: v,
                })
            }
        };
        positive("kernel width", self.kernel_width_m)?;
        positive("position step", self.position_step_m)?;
        positive("segment length", self.segment_s)?;
        positive("detrend length", self.detrend_s)?;
        positive("limit", self.limit_s)?;
        positive("lowest heart rate", self.min_rate_hz)?;
        if !(self.max_rate_hz.is_finite() && self.max_rate_hz > self.min_rate_hz) {
            return Err(WeakPulseError::Setting {
                what: "highest heart rate",
                rule: "finite and above the lowest",
                value: self.max_rate_hz,
            });
        }
        if !(self.margin_m.is_finite() && self.margin_m >= 0.0) {
            return Err(WeakPulseError::Setting {
                what: "margin",
                rule: "finite, not negative",
                value: self.margin_m,
            });
        }
        if !(8..=64).contains(&self.phase_bins) {
            return Err(WeakPulseError::Setting {
                what: "phase bins",
                rule: "8 to 64",
                value: self.phase_bins as f64,
            });
        }
        if !(self.beat_interval_cv.is_finite() && (0.0..0.5).contains(&self.beat_interval_cv)) {
            return Err(WeakPulseError::Setting {
                what: "beat-interval variability",
                rule: "at least 0 and under 0.5",
                value: self.beat_interval_cv,
            });
        }
        if !(self.rate_step_probability.is_finite()
            && (0.0..=0.5).contains(&self.rate_step_probability))
        {
            return Err(WeakPulseError::Setting {
                what: "rate step probability",
                rule: "0 to 0.5",
                value: self.rate_step_probability,
            });
        }
        for &r in &self.snr_per_root_s {
            positive("amplitude (SNR per root second)", r)?;
        }
        let rate = self.geometry.sample_rate_hz;
        if self.max_rate_hz * 2.0 * self.phase_bins as f64 > 10.0 * rate
            || self.detrend_s * self.min_rate_hz < 1.0
        {
            return Err(WeakPulseError::Setting {
                what: "detrend length x lowest rate",
                rule: "at least 1 (the average must span a whole beat), with the frame rate well above the fastest pulse",
                value: self.detrend_s * self.min_rate_hz,
            });
        }
        Ok(())
    }

    /// The trial rates: a step that moves the phase by 0.15 cycle over a segment.
    fn rates_hz(&self) -> Vec<f64> {
        let step = 0.15 / self.segment_s;
        let n = ((self.max_rate_hz - self.min_rate_hz) / step).ceil() as usize;
        (0..=n)
            .map(|i| {
                self.min_rate_hz
                    + i as f64 * (self.max_rate_hz - self.min_rate_hz) / n.max(1) as f64
            })
            .collect()
    }

    fn half_range_m(&self) -> f64 {
        (ELEMENTS as f64 - 1.0) / 2.0 * self.geometry.pitch_m + self.margin_m
    }

    fn positions_m(&self) -> Vec<f64> {
        let h = self.half_range_m();
        let n = (2.0 * h / self.position_step_m).round().max(1.0) as usize;
        (0..=n)
            .map(|i| -h + 2.0 * h * i as f64 / n as f64)
            .collect()
    }

    /// How many segment ends a window of `limit_s` holds.
    fn looks(&self, limit_s: f64) -> usize {
        ((limit_s / self.segment_s) - 1e-9).ceil().max(1.0) as usize
    }
}

/// Why a frame or a setting was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WeakPulseError {
    #[error("{what} must be {rule}, got {value}")]
    Setting {
        what: &'static str,
        rule: &'static str,
        value: f64,
    },
    #[error("array geometry: {0}")]
    Geometry(String),
    #[error("pulse waveform: {0}")]
    Waveform(&'static str),
    #[error("frame {seq} at {t_s} s is not finite; skipped")]
    NonFinite { seq: u64, t_s: f64 },
    #[error("frame {seq} at {t_s} s is not after the previous frame ({previous_s} s); skipped")]
    TimeOrder { seq: u64, t_s: f64, previous_s: f64 },
    #[error(
        "every element's signal is flat (no noise measured): nothing can be weighed; the segment ending at {elapsed_s} s was dropped"
    )]
    Flat { elapsed_s: f64 },
    #[error("{0}")]
    Calibration(String),
}

/// Where the felt pulse is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Found {
    /// Lateral offset of the artery from the sensor centre along tissue `z`, m.
    pub offset_z_m: f64,
    /// The same as a (fractional) element index.
    pub element: f64,
    /// Its standard error, m (infinite at the edge of the searched range).
    pub offset_se_m: f64,
    /// The best position is at the end of the searched range: only a bound.
    pub at_edge: bool,
    /// The heart's period at the decision, s (posterior mean of the rate).
    pub period_s: f64,
    /// Window length at the decision, s, and beats in it.
    pub elapsed_s: f64,
    pub beats: f64,
    /// The statistic at the decision, as an SNR (`√(2 ln Λ)`).
    pub snr: f64,
    /// The pulse's peak-to-peak at the kernel's peak fitted along the track, N (the
    /// template's shape assumed: a rough size, for comparing fixes of one artery).
    pub amplitude_n: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    Found(Found),
    /// The limit came first.
    NotFound {
        elapsed_s: f64,
    },
}

/// Reported at the end of every segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Data weighed so far, s, and the beats in it (at the current rate estimate).
    pub elapsed_s: f64,
    pub beats: f64,
    /// Log of the averaged likelihood ratio.
    pub log_ratio: f64,
    /// The evidence so far as an SNR, `√(2 max(ln Λ, 0))`, and what the threshold needs.
    pub snr: f64,
    pub snr_needed: f64,
    /// Beats still needed if the evidence keeps growing as it has (SNR ∝ √beats); `None`
    /// while there is no evidence to extrapolate.
    pub beats_to_go: Option<f64>,
    pub decision: Option<Decision>,
}

/// The streaming detector.
#[derive(Clone)]
pub struct WeakPulseDetector {
    settings: WeakPulseSettings,
    shape: PulseShape,
    threshold: f64,
    looks: usize,
    detrend: Detrend,
    folds: Folds,
    track: Track,
    kernel: SpatialKernel,
    positions_m: Vec<f64>,
    states: usize,
    start_s: Option<f64>,
    last_s: Option<f64>,
    segment: usize,
    done: usize,
    corr: Vec<f64>,
    energy: Vec<f64>,
    whitened: Vec<f64>,
    projected: Vec<f64>,
    decision: Option<Decision>,
    gaps: usize,
    /// Weighing on after a "found" (`keep_weighing`).
    weighing: bool,
}

impl std::fmt::Debug for WeakPulseDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WeakPulseDetector")
            .field("settings", &self.settings)
            .field("threshold", &self.threshold)
            .field("looks", &self.looks)
            .field("segments_done", &self.done)
            .field("decision", &self.decision)
            .finish_non_exhaustive()
    }
}

impl WeakPulseDetector {
    /// A detector whose threshold and window limit come from `threshold` (measured with
    /// the same settings and waveform by [`NoiseLaw::measure`]).
    pub fn new(
        settings: WeakPulseSettings,
        shape: PulseShape,
        threshold: &Threshold,
    ) -> Result<Self, WeakPulseError> {
        if threshold.settings != settings || threshold.shape != shape {
            return Err(WeakPulseError::Calibration(
                "the threshold was measured for other settings or another waveform".into(),
            ));
        }
        let looks = settings.looks(threshold.limit_s);
        Self::build(settings, shape, threshold.log_ratio, looks)
    }

    pub(super) fn build(
        settings: WeakPulseSettings,
        shape: PulseShape,
        threshold: f64,
        looks: usize,
    ) -> Result<Self, WeakPulseError> {
        settings.check()?;
        waveform::check(&shape).map_err(WeakPulseError::Waveform)?;
        let rates = settings.rates_hz();
        let b = settings.phase_bins;
        let templates = waveform::bin_templates(&shape, &rates, b)
            .ok_or(WeakPulseError::Waveform("the waveform is flat"))?;
        let positions_m = settings.positions_m();
        let fs = settings.geometry.sample_rate_hz;
        let states = rates.len() * b;
        let track = Track::new(TrackSettings {
            rates_hz: rates.clone(),
            bins: b,
            positions: positions_m.len(),
            amplitudes: settings
                .snr_per_root_s
                .iter()
                .map(|r| r / fs.sqrt())
                .collect(),
            segment_s: settings.segment_s,
            beat_interval_cv: settings.beat_interval_cv,
            rate_step_probability: settings.rate_step_probability,
        });
        Ok(Self {
            shape,
            detrend: Detrend::new((settings.detrend_s * fs).round() as usize),
            folds: Folds::new(rates, b, templates),
            track,
            kernel: SpatialKernel {
                pitch_m: settings.geometry.pitch_m,
                width_m: settings.kernel_width_m,
            },
            corr: vec![0.0; states * ELEMENTS],
            energy: vec![0.0; states],
            whitened: vec![0.0; states * ELEMENTS],
            projected: vec![0.0; positions_m.len() * states],
            positions_m,
            states,
            threshold,
            looks,
            settings,
            start_s: None,
            last_s: None,
            segment: 0,
            done: 0,
            decision: None,
            gaps: 0,
            weighing: false,
        })
    }

    /// The decision, once made.
    pub fn decision(&self) -> Option<Decision> {
        self.decision
    }

    /// After a "found", go on weighing frames: each segment fits the place again (its SE
    /// shrinking as the evidence grows) and reports it as the decision. For a caller that
    /// needs the place more precisely than the crossing gave it. Does nothing before a
    /// "found".
    pub fn keep_weighing(&mut self) {
        if matches!(self.decision, Some(Decision::Found(_))) {
            self.weighing = true;
        }
    }

    fn weighing_on(&self) -> bool {
        self.weighing && matches!(self.decision, Some(Decision::Found(_)))
    }

    /// Gaps (over five frame intervals) seen so far; the detrending restarts after each.
    pub fn gaps(&self) -> usize {
        self.gaps
    }

    /// Take one frame. Returns the progress at the end of each segment (every
    /// `segment_s`), `None` in between and after the decision.
    pub fn push(&mut self, frame: &TactileFrame) -> Result<Option<Progress>, WeakPulseError> {
        if self.decision.is_some() && !self.weighing_on() {
            return Ok(None);
        }
        if !frame.is_finite() {
            return Err(WeakPulseError::NonFinite {
                seq: frame.seq,
                t_s: frame.t_s,
            });
        }
        let mut contiguous = true;
        if let Some(previous_s) = self.last_s {
            if frame.t_s <= previous_s {
                return Err(WeakPulseError::TimeOrder {
                    seq: frame.seq,
                    t_s: frame.t_s,
                    previous_s,
                });
            }
            if frame.t_s - previous_s > 5.0 / self.settings.geometry.sample_rate_hz {
                contiguous = false;
                self.gaps += 1;
            }
        }
        self.last_s = Some(frame.t_s);
        let start = *self.start_s.get_or_insert(frame.t_s);
        let Some((t, y)) = self.detrend.push(frame.t_s, &frame.force_n, contiguous) else {
            return Ok(None);
        };
        let t_rel = t - start;
        let segment = (t_rel / self.settings.segment_s).floor().max(0.0) as usize;
        let mut report = Ok(None);
        while self.segment < segment && (self.decision.is_none() || self.weighing_on()) {
            report = self.finish_segment();
            self.segment += 1;
        }
        if self.decision.is_none() || self.weighing_on() {
            self.folds.add(t_rel, &y);
        }
        report
    }

    fn finish_segment(&mut self) -> Result<Option<Progress>, WeakPulseError> {
        let boundary_s = self.segment as f64 * self.settings.segment_s;
        self.done += 1;
        let elapsed_s = self.done as f64 * self.settings.segment_s;
        let sd = self.detrend.noise_sd();
        let top = sd.iter().copied().fold(0.0, f64::max);
        // An element with no measured noise is taken as stuck and left out.
        let inverse_sd: [f64; ELEMENTS] = std::array::from_fn(|e| {
            if top > 0.0 && sd[e] > 1e-9 * top {
                1.0 / sd[e]
            } else {
                0.0
            }
        });
        if top <= 0.0 || !top.is_finite() {
            self.folds.clear();
            if self.done >= self.looks {
                self.decision = Some(Decision::NotFound { elapsed_s });
            }
            return Err(WeakPulseError::Flat { elapsed_s });
        }
        self.folds.correlate(&mut self.corr, &mut self.energy);
        self.folds.clear();
        for (s, w) in self.whitened.chunks_exact_mut(ELEMENTS).enumerate() {
            for e in 0..ELEMENTS {
                w[e] = self.corr[s * ELEMENTS + e] * inverse_sd[e];
            }
        }
        let ns = self.states;
        for (x, &at) in self.positions_m.iter().enumerate() {
            let v = self.kernel.whitened(at, &inverse_sd);
            let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            let unit: [f64; ELEMENTS] =
                std::array::from_fn(|e| if norm > 0.0 { v[e] / norm } else { 0.0 });
            for s in 0..ns {
                let w = &self.whitened[s * ELEMENTS..(s + 1) * ELEMENTS];
                self.projected[x * ns + s] = unit.iter().zip(w).map(|(a, b)| a * b).sum();
            }
        }
        self.track
            .update(boundary_s, &self.projected, &self.energy, &self.whitened);
        let log_ratio = self.track.log_ratio();
        let by_position = self.track.position_log_ratios();
        let best = by_position
            .iter()
            .enumerate()
            .fold(
                (0, f64::NEG_INFINITY),
                |a, (i, &v)| if v > a.1 { (i, v) } else { a },
            )
            .0;
        let rate_hz = self.track.rate_hz(best);
        let beats = elapsed_s * if rate_hz.is_finite() { rate_hz } else { 0.0 };
        let snr = (2.0 * log_ratio.max(0.0)).sqrt();
        let snr_needed = (2.0 * self.threshold.max(0.0)).sqrt();
        let beats_to_go = (snr > 0.0 && snr_needed.is_finite() && beats > 0.0)
            .then(|| (beats * ((snr_needed / snr).powi(2) - 1.0)).max(0.0));
        // Found once the threshold is crossed; while weighing on after that, the place is
        // fitted again at each segment along the track as it now stands.
        if log_ratio > self.threshold || self.weighing_on() {
            let (path, _) = self.track.best_path(best);
            if path.energy > 0.0 {
                let z: [f64; ELEMENTS] =
                    std::array::from_fn(|e| path.elements[e] / path.energy.sqrt());
                if let Some(placed) =
                    locate::place(&self.kernel, &z, &inverse_sd, self.settings.half_range_m())
                {
                    let g = &self.settings.geometry;
                    let amplitude_n = placed.amplitude / path.energy.sqrt()
                        * waveform::peak_to_peak_per_rms(&self.shape, rate_hz).unwrap_or(f64::NAN);
                    let middle = (ELEMENTS as f64 - 1.0) / 2.0;
                    self.decision = Some(Decision::Found(Found {
                        offset_z_m: g.direction * placed.x_m,
                        element: middle + placed.x_m / g.pitch_m,
                        offset_se_m: placed.se_m,
                        at_edge: placed.at_edge,
                        period_s: 1.0 / rate_hz,
                        elapsed_s,
                        beats,
                        snr,
                        amplitude_n,
                    }));
                }
            }
        }
        if self.decision.is_none() && self.done >= self.looks {
            self.decision = Some(Decision::NotFound { elapsed_s });
        }
        Ok(Some(Progress {
            elapsed_s,
            beats,
            log_ratio,
            snr,
            snr_needed,
            beats_to_go,
            decision: self.decision,
        }))
    }

    /// Feed frames until the window's looks are all made, for the noise law: the log
    /// ratio at each segment end.
    pub(super) fn log_ratio_now(&self) -> f64 {
        self.track.log_ratio()
    }

    pub(super) fn segments_done(&self) -> usize {
        self.done
    }
}

#[cfg(test)]
#[path = "detector_tests.rs"]
mod tests;
