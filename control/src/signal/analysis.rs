//! One acquisition analysed the seed's way: band-pass, detect the pulse, localize it.
//!
//! The analyzer owns the filter and a filtered copy of the window, both allocated at
//! construction; analysing never allocates. Which peak it uses:
//! - the peak is the centre of the *last* complete pulse in the window (the most recent
//!   phase; the seed takes the phase from the current window's centres);
//! - the off-peak point is half the running period estimate before it (between that pulse
//!   and the one before, which exists because detection needs two complete pulses);
//! - the running estimate used is the current one averaged with this window's period, the
//!   value the caller commits if it accepts the finding.

use super::bandpass::{BandPass, BandPassSpec, FilterDesignError};
use super::detect::{DetectorSettings, NoPulse, PulseTiming, detect_pulse};
use super::localize::{Localization, LocalizerSettings, NotLocated, localize};
use super::period::RunningPeriod;
use super::window::{AcquisitionWindow, Channels};
use crate::types::ELEMENTS;

/// Everything the analysis needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalysisSettings {
    pub band: BandPassSpec,
    pub detector: DetectorSettings,
    pub localizer: LocalizerSettings,
    /// Localize on the band-passed window (true) or on the raw forces (false).
    pub localize_filtered: bool,
}

/// A pulse found and localized in one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseFinding {
    pub timing: PulseTiming,
    pub localization: Localization,
    /// The running period estimate with this window folded in, s.
    pub period_estimate_s: f64,
    /// Times of the peak and off-peak samples used, s.
    pub peak_t_s: f64,
    pub off_peak_t_s: f64,
}

/// Why an acquisition found no artery.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum NoPulseFound {
    #[error("no pulse: {0}")]
    NoPulse(#[from] NoPulse),
    #[error("pulse timing found (period {:.3} s) but not located: {reason}", timing.period_s)]
    NotLocated {
        timing: PulseTiming,
        reason: NotLocated,
    },
}

/// The seed's signal chain with its buffers.
#[derive(Debug, Clone)]
pub struct PulseAnalyzer {
    settings: AnalysisSettings,
    filter: BandPass,
    capacity: usize,
    len: usize,
    filtered: Vec<f64>,
}

impl PulseAnalyzer {
    /// An analyzer for windows of up to `capacity_samples` samples.
    pub fn new(
        settings: AnalysisSettings,
        capacity_samples: usize,
    ) -> Result<Self, FilterDesignError> {
        let filter = BandPass::design(settings.band)?;
        let capacity = capacity_samples.max(1);
        Ok(Self {
            settings,
            filter,
            capacity,
            len: 0,
            filtered: vec![0.0; capacity * ELEMENTS],
        })
    }

    pub fn settings(&self) -> &AnalysisSettings {
        &self.settings
    }

    pub fn filter(&self) -> &BandPass {
        &self.filter
    }

    /// The band-passed copy of the last analysed window.
    pub fn filtered(&self) -> Channels<'_> {
        Channels::new(&self.filtered, self.capacity, self.len)
            .expect("the filtered buffer holds ELEMENTS rows of `capacity` samples")
    }

    /// Analyse a window given the running period estimate (not modified: commit
    /// `period_estimate_s` of a finding you accept).
    pub fn analyse(
        &mut self,
        window: &AcquisitionWindow,
        period: &RunningPeriod,
    ) -> Result<PulseFinding, NoPulseFound> {
        let raw = window.channels();
        // A window larger than this analyzer's buffers is analysed over its first part.
        self.len = raw.len().min(self.capacity);
        if self.len == 0 {
            return Err(NoPulse::Empty.into());
        }
        let raw = raw.truncated(self.len);
        if (0..ELEMENTS).all(|e| is_flat(raw.element(e))) {
            return Err(NoPulse::Flat.into());
        }
        for e in 0..ELEMENTS {
            let out = &mut self.filtered[e * self.capacity..][..self.len];
            self.filter.apply(raw.element(e), out);
        }
        let filtered = self.filtered();
        let timing = detect_pulse(&filtered, window.dt_s(), &self.settings.detector)?;
        let period_estimate_s = period.with(timing.period_s);
        let peak = timing.last_centre;
        let off_peak = peak - 0.5 * period_estimate_s / window.dt_s();
        let source = if self.settings.localize_filtered {
            filtered
        } else {
            raw
        };
        let localization = localize(
            &source,
            timing.element,
            peak,
            off_peak,
            &self.settings.localizer,
        )
        .map_err(|reason| NoPulseFound::NotLocated { timing, reason })?;
        Ok(PulseFinding {
            timing,
            localization,
            period_estimate_s,
            peak_t_s: window.time_of(peak),
            off_peak_t_s: window.time_of(off_peak),
        })
    }
}

/// No change beyond rounding (relative to the level, N): nothing can pulse in it.
fn is_flat(series: &[f64]) -> bool {
    let (lo, hi) = series
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    hi - lo <= 1e-12 * (1.0 + lo.abs().max(hi.abs()))
}
