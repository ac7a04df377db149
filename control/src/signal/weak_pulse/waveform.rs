//! The pulse's temporal template: a generic arterial pressure waveform, or one the caller
//! learned, turned into one template per trial heart rate over the fold's phase bins.
//!
//! The generic shape is a systolic peak, a reflected wave and a diastolic decay after the
//! dicrotic notch. Systole lasts about the same time whatever the rate (it shortens only
//! with the square root of the period), so the shape is built in seconds from the beat's
//! onset, not as a fixed fraction of the period.

/// The waveform the detector matches.
#[derive(Debug, Clone, PartialEq)]
pub enum PulseShape {
    /// [`generic_pressure`].
    Generic,
    /// One beat learned from the patient, sampled evenly in phase from the beat's onset
    /// (at least 8 samples; any scale and offset).
    Learned(Vec<f64>),
}

/// A generic arterial pressure pulse (no unit; peak near 1) `tau_s` after the beat's onset
/// for a beat lasting `period_s`.
pub fn generic_pressure(tau_s: f64, period_s: f64) -> f64 {
    let k = (period_s / 0.9).sqrt().clamp(0.6, 1.3);
    let bump =
        |centre: f64, width: f64| (-0.5 * ((tau_s - centre * k) / (width * k)).powi(2)).exp();
    let notch = 0.36 * k;
    let after_notch = 1.0 / (1.0 + (-(tau_s - notch) / 0.015).exp());
    let decay = (-(tau_s - notch).max(0.0) / (0.45 * period_s)).exp();
    bump(0.11, 0.04) + 0.55 * bump(0.26, 0.06) + 0.4 * after_notch * decay
}

/// Templates over `bins` phase bins for each rate: each bin the waveform's mean over it,
/// the mean over bins removed and scaled to unit RMS (so a segment's template energy is
/// about its sample count). `None` when the shape is flat or malformed.
pub(super) fn bin_templates(shape: &PulseShape, rates_hz: &[f64], bins: usize) -> Option<Vec<f64>> {
    const SUB: usize = 8;
    let mut out = Vec::with_capacity(rates_hz.len() * bins);
    for &f in rates_hz {
        let period = 1.0 / f;
        let value = |phase: f64| match shape {
            PulseShape::Generic => generic_pressure(phase * period, period),
            PulseShape::Learned(w) => interpolate(w, phase),
        };
        let mut t: Vec<f64> = (0..bins)
            .map(|b| {
                (0..SUB)
                    .map(|i| value((b as f64 + (i as f64 + 0.5) / SUB as f64) / bins as f64))
                    .sum::<f64>()
                    / SUB as f64
            })
            .collect();
        let mean = t.iter().sum::<f64>() / bins as f64;
        t.iter_mut().for_each(|v| *v -= mean);
        let rms = (t.iter().map(|v| v * v).sum::<f64>() / bins as f64).sqrt();
        if !(rms.is_finite() && rms > 0.0) {
            return None;
        }
        out.extend(t.iter().map(|v| v / rms));
    }
    Some(out)
}

/// The shape's peak-to-peak over its RMS at `rate_hz` (to turn a fitted RMS amplitude into
/// the peak-to-peak a clinician reads); `None` for a flat shape.
pub(super) fn peak_to_peak_per_rms(shape: &PulseShape, rate_hz: f64) -> Option<f64> {
    let t = bin_templates(shape, &[rate_hz], 64)?;
    let (lo, hi) = t
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (hi > lo).then_some(hi - lo)
}

/// Periodic linear interpolation of one beat sampled evenly in phase.
fn interpolate(w: &[f64], phase: f64) -> f64 {
    let n = w.len();
    let x = phase.rem_euclid(1.0) * n as f64;
    let i = (x.floor() as usize).min(n - 1);
    let frac = x - i as f64;
    w[i] * (1.0 - frac) + w[(i + 1) % n] * frac
}

/// Whether a learned shape can serve as a template.
pub(super) fn check(shape: &PulseShape) -> Result<(), &'static str> {
    match shape {
        PulseShape::Generic => Ok(()),
        PulseShape::Learned(w) if w.len() < 8 => Err("a learned waveform needs at least 8 samples"),
        PulseShape::Learned(w) if w.iter().any(|v| !v.is_finite()) => {
            Err("a learned waveform must be finite")
        }
        PulseShape::Learned(_) => Ok(()),
    }
}
