//! Pulse detection and timing, as the seed describes it (its equations 1 to 3).
//!
//! 1. The element `i*` with the largest max − min over the (filtered) window.
//! 2. Its samples above `min + fraction × (max − min)` (the seed: 2/3) form runs.
//! 3. Runs that touch either end of the window are dropped: they may be partial pulses.
//! 4. Each remaining run's centre, the mean of its first and last sample, is a pulse time.
//! 5. The period is the mean spacing of consecutive centres; since the spacings telescope,
//!    that is `(last − first) / (runs − 1)`.
//!
//! Fewer than two complete runs, a flat or non-finite signal, or a period outside the
//! allowed range give [`NoPulse`], never a NaN. The range check is ours, not the seed's:
//! a "period" outside the band-pass's own pass band is noise shaped by the filter, not a
//! pulse (docs/signal-processing.md).

use super::window::Channels;
use crate::types::ELEMENTS;

/// Settings of the detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorSettings {
    /// Threshold as a fraction of max − min above min (the seed: 2/3).
    pub threshold_fraction: f64,
    /// Accepted pulse periods, s.
    pub min_period_s: f64,
    pub max_period_s: f64,
}

/// Pulse timing found in one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseTiming {
    /// The element with the largest swing, `i*`.
    pub element: usize,
    /// Its max − min, in the units of the input (N).
    pub swing: f64,
    /// Complete runs over threshold (pulses), at least 2.
    pub pulses: usize,
    /// Centre of the first and last complete run, sample index (may be x.5).
    pub first_centre: f64,
    pub last_centre: f64,
    /// Mean spacing of the centres, s.
    pub period_s: f64,
}

/// Why no pulse was detected.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum NoPulse {
    #[error("the window is empty")]
    Empty,
    #[error("the signal is flat or not finite")]
    Flat,
    #[error("{complete} complete pulse(s) in the window; need at least 2")]
    TooFewPulses { complete: usize },
    #[error("period {period_s:.3} s is outside {min_s:.3} to {max_s:.3} s")]
    PeriodOutOfRange {
        period_s: f64,
        min_s: f64,
        max_s: f64,
    },
}

/// The element with the largest finite max − min (the first of equals) and its swing.
pub fn strongest_element(channels: &Channels<'_>) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for e in 0..ELEMENTS {
        let (lo, hi) = min_max(channels.element(e))?;
        let swing = hi - lo;
        if swing.is_finite() && best.is_none_or(|(_, s)| swing > s) {
            best = Some((e, swing));
        }
    }
    best
}

/// Detect the pulse in a window sampled every `dt_s` seconds.
pub fn detect_pulse(
    channels: &Channels<'_>,
    dt_s: f64,
    settings: &DetectorSettings,
) -> Result<PulseTiming, NoPulse> {
    if channels.is_empty() {
        return Err(NoPulse::Empty);
    }
    let (element, swing) = strongest_element(channels).ok_or(NoPulse::Flat)?;
    let series = channels.element(element);
    let (lo, hi) = min_max(series).ok_or(NoPulse::Flat)?;
    // A swing lost in rounding is flat: nothing can be over a threshold inside it.
    let scale = lo.abs().max(hi.abs());
    if swing <= 64.0 * f64::EPSILON * scale {
        return Err(NoPulse::Flat);
    }
    let threshold = lo + settings.threshold_fraction * swing;
    let runs = complete_runs(series, threshold);
    if runs.count < 2 {
        return Err(NoPulse::TooFewPulses {
            complete: runs.count,
        });
    }
    let period_s = (runs.last - runs.first) / (runs.count - 1) as f64 * dt_s;
    if !(period_s >= settings.min_period_s && period_s <= settings.max_period_s) {
        return Err(NoPulse::PeriodOutOfRange {
            period_s,
            min_s: settings.min_period_s,
            max_s: settings.max_period_s,
        });
    }
    Ok(PulseTiming {
        element,
        swing,
        pulses: runs.count,
        first_centre: runs.first,
        last_centre: runs.last,
        period_s,
    })
}

/// Complete runs over a threshold: how many, and the first and last centre.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Runs {
    count: usize,
    first: f64,
    last: f64,
}

fn complete_runs(series: &[f64], threshold: f64) -> Runs {
    let n = series.len();
    let mut runs = Runs {
        count: 0,
        first: 0.0,
        last: 0.0,
    };
    let mut start: Option<usize> = None;
    for (j, &a) in series.iter().enumerate() {
        match (a > threshold, start) {
            (true, None) => start = Some(j),
            (false, Some(s)) => {
                record(&mut runs, s, j - 1, n);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        record(&mut runs, s, n - 1, n);
    }
    runs
}

fn record(runs: &mut Runs, start: usize, stop: usize, n: usize) {
    // The seed ignores runs that abut the beginning or end of the window.
    if start == 0 || stop + 1 == n {
        return;
    }
    let centre = (start + stop) as f64 / 2.0;
    if runs.count == 0 {
        runs.first = centre;
    }
    runs.last = centre;
    runs.count += 1;
}

fn min_max(series: &[f64]) -> Option<(f64, f64)> {
    let mut it = series.iter().copied();
    let first = it.next()?;
    let (lo, hi) = it.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v)));
    (lo.is_finite() && hi.is_finite() && series.iter().all(|v| v.is_finite())).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_touching_the_ends_are_dropped() {
        let s = [5.0, 5.0, 0.0, 5.0, 5.0, 0.0, 0.0, 5.0, 0.0, 5.0];
        let r = complete_runs(&s, 2.0);
        assert_eq!(r.count, 2);
        assert_eq!(r.first, 3.5);
        assert_eq!(r.last, 7.0);
        // A run that covers the whole window touches both ends.
        assert_eq!(complete_runs(&[1.0; 4], 0.0).count, 0);
    }
}
