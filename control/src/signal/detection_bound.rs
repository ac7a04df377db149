//! The weakest pulse the physics lets an ideal detector feel: beats needed to decide, and
//! how well the artery's position can then be known (issue 18).
//!
//! The ideal detector knows the pulse's waveform and timing and the array's pressure
//! kernel, and not where on the array the artery lies or how strong its pulse is. Each
//! element's samples over `N` beats, filtered with the waveform (its mean removed: every
//! element's static load is unknown), give one number per element,
//! `z_e = s_e(x0) ‖w‖ √N / σ + n_e` with `n_e` independent unit normals, where `s_e(x0)` is
//! element `e`'s force per pascal with the artery at `x0` and `w` the pulse pressure over
//! one beat. So:
//! - **Known position** (the matched filter): the statistic `⟨ŝ(x0), z⟩` has SNR
//!   `d = ‖s(x0)‖ ‖w‖ √N / σ`; it detects with probability `pd` at false-alarm rate `pfa`
//!   once `d ≥ Q⁻¹(pfa) + Q⁻¹(1 − pd)`.
//! - **Unknown position** (the generalized likelihood ratio over `x0`): the largest
//!   `⟨ŝ(x), z⟩` over positions. Its noise-only law does not depend on `N`; its threshold
//!   for `pfa` is measured by Monte Carlo on unit normals the caller draws (this crate has
//!   no random numbers). The true position's term alone crosses it with probability `pd`
//!   once `d ≥ η + Q⁻¹(1 − pd)`, so the beats this gives are an upper bound on what the
//!   ideal unknown-position detector needs (the maximum can only be larger), and close to
//!   it where the signal is strong enough to be felt at all.
//! - **Position**: the Cramér-Rao bound on `x0` after `N` beats, with the amplitude a
//!   nuisance: `1 / (c² (‖s'‖² − ⟨s, s'⟩² / ‖s‖²))`, `c = ‖w‖ √N / σ`, `s'` the kernel's
//!   derivative along the array (by central differences on the caller's table).

use crate::types::ELEMENTS;

/// Why no bound.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BoundError {
    #[error("{what} must be {rule}, got {value}")]
    Bad {
        what: &'static str,
        rule: &'static str,
        value: f64,
    },
    #[error("the kernel table needs at least 3 positions in increasing order, got {0}")]
    Table(usize),
    #[error("the pulse gives no signal at this position (kernel or waveform all zero)")]
    NoSignal,
}

/// The pulse's per-beat signal at one artery position on the array.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerBeat {
    /// Matched-filter SNR of one beat with the position known.
    pub snr: f64,
    /// Position Fisher information of one beat (amplitude unknown), 1/m².
    pub position_information_per_m2: f64,
}

/// The waveform's energy over one beat with its mean removed, Pa²·samples.
pub fn waveform_energy(waveform_pa: &[f64]) -> f64 {
    if waveform_pa.is_empty() {
        return 0.0;
    }
    let mean = waveform_pa.iter().sum::<f64>() / waveform_pa.len() as f64;
    waveform_pa.iter().map(|w| (w - mean).powi(2)).sum()
}

/// One beat's signal with the artery at table row `at` (`table[i] = (offset m, force per
/// pascal on each element)`, offsets increasing), for a waveform of energy `energy` (from
/// [`waveform_energy`]) and element noise `noise_sd_n`.
pub fn per_beat(
    table: &[(f64, [f64; ELEMENTS])],
    at: usize,
    energy_pa2: f64,
    noise_sd_n: f64,
) -> Result<PerBeat, BoundError> {
    positive("noise SD", noise_sd_n)?;
    positive("waveform energy", energy_pa2)?;
    check_table(table)?;
    if at >= table.len() {
        return Err(BoundError::Table(table.len()));
    }
    let s = &table[at].1;
    let (lo, hi) = (at.saturating_sub(1), (at + 1).min(table.len() - 1));
    let dx = table[hi].0 - table[lo].0;
    let ds: [f64; ELEMENTS] = std::array::from_fn(|e| (table[hi].1[e] - table[lo].1[e]) / dx);
    let ss: f64 = s.iter().map(|v| v * v).sum();
    if ss <= 0.0 {
        return Err(BoundError::NoSignal);
    }
    let sd: f64 = s.iter().zip(&ds).map(|(a, b)| a * b).sum();
    let dd: f64 = ds.iter().map(|v| v * v).sum();
    let c2 = energy_pa2 / (noise_sd_n * noise_sd_n);
    Ok(PerBeat {
        snr: (ss * c2).sqrt(),
        position_information_per_m2: (c2 * (dd - sd * sd / ss)).max(0.0),
    })
}

/// Beats for the matched filter's SNR to reach `needed` (at least one).
pub fn beats_for(needed_snr: f64, per_beat_snr: f64) -> f64 {
    (needed_snr / per_beat_snr).powi(2).max(1.0)
}

/// The SNR a detector whose noise-only threshold is `threshold` (in unit-normal terms)
/// needs to detect with probability `pd`.
pub fn snr_needed(threshold: f64, pd: f64) -> Result<f64, BoundError> {
    if !(pd > 0.0 && pd < 1.0) {
        return Err(BoundError::Bad {
            what: "detection probability",
            rule: "between 0 and 1",
            value: pd,
        });
    }
    Ok(threshold + normal_quantile(pd))
}

/// The known-position detector's threshold for false-alarm rate `pfa`.
pub fn known_position_threshold(pfa: f64) -> Result<f64, BoundError> {
    probability("false-alarm rate", pfa)?;
    Ok(normal_quantile(1.0 - pfa))
}

/// The unknown-position detector's threshold for `pfa`, measured: the `1 - pfa` quantile
/// of `max_x ⟨ŝ(x), n⟩` over `draws` noise-only draws, `normal` giving unit normals.
pub fn glrt_threshold(
    table: &[(f64, [f64; ELEMENTS])],
    pfa: f64,
    draws: usize,
    normal: &mut impl FnMut() -> f64,
) -> Result<f64, BoundError> {
    probability("false-alarm rate", pfa)?;
    check_table(table)?;
    if (draws as f64) * pfa < 10.0 {
        return Err(BoundError::Bad {
            what: "draws x false-alarm rate",
            rule: "at least 10 (too few false alarms to place the threshold)",
            value: draws as f64 * pfa,
        });
    }
    let units: Vec<[f64; ELEMENTS]> = table
        .iter()
        .filter_map(|(_, s)| {
            let n = s.iter().map(|v| v * v).sum::<f64>().sqrt();
            (n > 0.0).then(|| std::array::from_fn(|e| s[e] / n))
        })
        .collect();
    if units.is_empty() {
        return Err(BoundError::NoSignal);
    }
    let mut maxima = Vec::with_capacity(draws);
    for _ in 0..draws {
        let z: [f64; ELEMENTS] = std::array::from_fn(|_| normal());
        let best = units
            .iter()
            .map(|u| u.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>())
            .fold(f64::NEG_INFINITY, f64::max);
        maxima.push(best);
    }
    maxima.sort_by(f64::total_cmp);
    let k = (((1.0 - pfa) * draws as f64).ceil() as usize).min(draws - 1);
    Ok(maxima[k])
}

/// Chi-square quantile (Wilson-Hilferty: within a few per cent from 2 degrees of freedom up,
/// which is all a threshold at 1e-2 to 1e-4 needs).
pub fn chi2_quantile(p: f64, dof: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + normal_quantile(p) * a.sqrt()).powi(3)
}

/// Standard normal quantile (Acklam's rational approximation, relative error 1.2e-9):
/// a few lines here rather than a statistics crate for one function.
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    if !(p > 0.0 && p < 1.0) {
        return if p <= 0.0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
    }
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

fn positive(what: &'static str, v: f64) -> Result<(), BoundError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(BoundError::Bad {
            what,
            rule: "positive and finite",
            value: v,
        })
    }
}

fn probability(what: &'static str, v: f64) -> Result<(), BoundError> {
    if v > 0.0 && v < 1.0 {
        Ok(())
    } else {
        Err(BoundError::Bad {
            what,
            rule: "between 0 and 1",
            value: v,
        })
    }
}

fn check_table(table: &[(f64, [f64; ELEMENTS])]) -> Result<(), BoundError> {
    let ordered = table.windows(2).all(|w| w[1].0 > w[0].0);
    let finite = table
        .iter()
        .all(|(x, s)| x.is_finite() && s.iter().all(|v| v.is_finite()));
    if table.len() < 3 || !ordered || !finite {
        return Err(BoundError::Table(table.len()));
    }
    Ok(())
}

#[cfg(test)]
#[path = "detection_bound_tests.rs"]
mod tests;
