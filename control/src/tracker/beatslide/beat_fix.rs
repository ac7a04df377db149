//! One fix while sliding: where the artery lay on the array over the last beat (or beats).
//!
//! 1. Lock-in: every element's samples in the window are fitted with a line and the
//!    pulse's harmonics at the clock's phase ([`HarmonicFit`], linear trend: a window is
//!    one beat). The slow change of the contact load while sliding goes into the line.
//! 2. Timing: the elements are summed with the weights of the last fix's kernel (the
//!    spatial matched filter) and the learned waveform is slid in time over ±`max_delay`
//!    of a period to match that sum: how late this beat came, for the beat clock.
//! 3. Amplitudes: each element's multiple of the waveform at that delay (the temporal
//!    matched filter), with its standard error from the fit and the measured noise.
//! 4. Position: the kernel fitted across the ten amplitudes ([`fit_kernel`]).
//!
//! An irregular heart's window that one delay cannot fix is analysed again with each beat
//! timed on its own ([`analyse_window_beat_by_beat`]).
//!
//! The point is reported at the mean believed sensor position over the window: the
//! localization averages the window, and the sensor slides along the artery, so the
//! artery's place on the array changes little within it.

use crate::frames::SurfacePoint;
use crate::sensor::ArrayGeometry;
use crate::signal::harmonic::{
    HarmonicFit, HarmonicFitError, PulsePhase, Trend, Waveform, fundamental_delay_rad,
    shift_waveform,
};
use crate::signal::kernel_fit::{KernelFit, KernelFitError, element_kernel, fit_kernel};
use crate::signal::noise_level::NoiseLevel;
use crate::types::ELEMENTS;

use super::history::Window;

/// Delays tried on each side of zero (plus a parabolic refinement).
const DELAY_STEPS: usize = 16;

/// What a window gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatFix {
    /// Middle of the window, s.
    pub t_mid_s: f64,
    /// How late the beat came against the clock, s.
    pub late_s: f64,
    pub kernel: KernelFit,
    /// Mean believed sensor position over the window.
    pub sensor: SurfacePoint,
    /// Mean direction of the sensor's lag behind the belief over the window.
    pub lag_dir: [f64; 2],
    /// Mean of where the arm's load put the sensor less the belief over the window, m, if
    /// every frame had that reading.
    pub felt_offset: Option<[f64; 2]>,
    /// Noise SD used, N.
    pub noise_sd_n: f64,
    /// The elements' sum (with the kernel weights), shifted back to the clock's phase:
    /// this beat's waveform, for learning the template.
    pub aligned: Waveform,
}

impl BeatFix {
    /// Was the window timed against the beat clock? An untimed fix (`machine/sliding.rs`,
    /// from the window's coherent spatial pattern) carries no waveform.
    pub fn is_timed(&self) -> bool {
        self.aligned.norm() > 0.0
    }

    /// The artery point in believed coordinates: the believed sensor centre plus the
    /// artery's offset on the array (the sensor's lag not removed).
    pub fn point(&self) -> SurfacePoint {
        SurfacePoint::new(self.sensor.x_m, self.sensor.z_m + self.kernel.offset_z_m)
    }
}

/// Why a window gave no fix.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BeatMiss {
    #[error("the window holds no usable frames or positions")]
    Empty,
    #[error(transparent)]
    Fit(#[from] HarmonicFitError),
    #[error("the waveform carries no information in this window")]
    NoInformation,
    #[error(transparent)]
    Kernel(#[from] KernelFitError),
}

/// Where the last fix put the artery, for the spatial weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpatialPrior {
    pub element: f64,
    pub width_m: f64,
}

/// What both analyses of a window take and give ([`analyse_window`],
/// [`analyse_window_beat_by_beat`]).
pub type WindowAnalysis = fn(
    &Window<'_>,
    PulsePhase,
    &Waveform,
    SpatialPrior,
    f64,
    f64,
    &ArrayGeometry,
    &mut NoiseLevel,
) -> Result<BeatFix, BeatMiss>;

/// A window's harmonic fit at the clock's phase, and the noise SD its amplitudes are judged
/// by (as estimated from the window, never below the configured).
fn fit_window(
    window: &Window<'_>,
    phase: PulsePhase,
    configured_noise_sd_n: f64,
    noise: &mut NoiseLevel,
) -> Result<(HarmonicFit, f64), BeatMiss> {
    if window.mean_sensor().is_none() {
        return Err(BeatMiss::Empty);
    }
    let fit = HarmonicFit::fit(window.frames(), phase, Trend::Linear)?;
    let sigma = noise
        .estimate(window.frames())
        .unwrap_or(configured_noise_sd_n)
        .max(configured_noise_sd_n);
    Ok((fit, sigma))
}

/// Analyse one window.
#[allow(clippy::too_many_arguments)]
pub fn analyse_window(
    window: &Window<'_>,
    phase: PulsePhase,
    template: &Waveform,
    prior: SpatialPrior,
    max_delay_fraction: f64,
    configured_noise_sd_n: f64,
    geometry: &ArrayGeometry,
    noise: &mut NoiseLevel,
) -> Result<BeatFix, BeatMiss> {
    let (fit, sigma) = fit_window(window, phase, configured_noise_sd_n, noise)?;
    let weights = spatial_weights(prior, geometry);
    let combined = fit.combine(&weights);
    let max_delay = max_delay_fraction.clamp(0.0, 0.5) * std::f64::consts::TAU;
    let delay = best_delay(|q| combined_score(&fit, &combined, q), template, max_delay);
    let timed = Timed {
        template,
        combined: &combined,
        delay_rad: delay,
        phase,
    };
    fix_timed(window, &fit, &timed, sigma, geometry)
}

/// Analyse one window timed on the whole array, wherever the pulse lies on it, instead of
/// at the prior's place ([`analyse_window`]). The prior is where the last fix put the
/// artery; tissue moving under the sensor (breathing) carries it a few elements away
/// between two fixes, the prior's weights then combine elements with little pulse, the
/// delay is fitted to noise and a clear pulse is missed: on the breathing family a third of
/// the sliding windows failed so with the pulse plain on the array. It is the second look
/// at a window the prior's timing could not fix, not the first: on the whole array a
/// pulsating lump beside the artery can be the clearer pulse.
#[allow(clippy::too_many_arguments)]
pub fn analyse_window_on_array(
    window: &Window<'_>,
    phase: PulsePhase,
    template: &Waveform,
    prior: SpatialPrior,
    max_delay_fraction: f64,
    configured_noise_sd_n: f64,
    geometry: &ArrayGeometry,
    noise: &mut NoiseLevel,
) -> Result<BeatFix, BeatMiss> {
    let (fit, sigma) = fit_window(window, phase, configured_noise_sd_n, noise)?;
    let max_delay = max_delay_fraction.clamp(0.0, 0.5) * std::f64::consts::TAU;
    let delay = best_delay(|q| array_score(&fit, q), template, max_delay);
    let prior_combined = fit.combine(&spatial_weights(prior, geometry));
    let timed = Timed {
        template,
        combined: &prior_combined,
        delay_rad: delay,
        phase,
    };
    let mut fix = fix_timed(window, &fit, &timed, sigma, geometry)?;
    // The waveform the template learns from is combined where the pulse was found.
    let found = SpatialPrior {
        element: fix.kernel.element,
        width_m: fix.kernel.width_m,
    };
    if found.element.is_finite() && found.width_m.is_finite() && found.width_m > 0.0 {
        fix.aligned = shift_waveform(&fit.combine(&spatial_weights(found, geometry)), -delay);
    }
    Ok(fix)
}

/// One delay for a whole window: the pulse's `template` and the spatially `combined`
/// coefficients, timed `delay_rad` after the clock's `phase`.
struct Timed<'a> {
    template: &'a Waveform,
    combined: &'a Waveform,
    delay_rad: f64,
    phase: PulsePhase,
}

/// The fix from a window's fit at one delay ([`fix_at`]).
fn fix_timed(
    window: &Window<'_>,
    fit: &HarmonicFit,
    timed: &Timed<'_>,
    sigma: f64,
    geometry: &ArrayGeometry,
) -> Result<BeatFix, BeatMiss> {
    fix_at(
        window,
        fit,
        &shift_waveform(timed.template, timed.delay_rad),
        timed.delay_rad / timed.phase.omega_rad_s(),
        shift_waveform(timed.combined, -timed.delay_rad),
        sigma,
        geometry,
    )
}

/// The fix from a window's fit: each element's amplitude along the timed waveform `q`, the
/// kernel across them, and the window's mean sensor place, lag and load.
fn fix_at(
    window: &Window<'_>,
    fit: &HarmonicFit,
    q: &Waveform,
    late_s: f64,
    aligned: Waveform,
    sigma: f64,
    geometry: &ArrayGeometry,
) -> Result<BeatFix, BeatMiss> {
    let sensor = window.mean_sensor().ok_or(BeatMiss::Empty)?;
    let projection = fit.project(q).ok_or(BeatMiss::NoInformation)?;
    let kernel = fit_kernel(
        &projection.amplitude_n,
        projection.se_per_sigma * sigma,
        geometry,
    )?;
    Ok(BeatFix {
        t_mid_s: 0.5 * (fit.t_first_s + fit.t_last_s),
        late_s,
        kernel,
        sensor,
        lag_dir: window.mean_lag(),
        felt_offset: window.mean_felt_offset(),
        noise_sd_n: sigma,
        aligned,
    })
}

/// Most beats one window is timed beat by beat over ([`analyse_window_beat_by_beat`]).
const MAX_TIMED_BEATS: usize = 40;
/// Least share of a period a beat must have in the window to be timed on its own.
const MIN_BEAT_COVER: f64 = 0.75;

/// Analyse one window of an irregular heart beat by beat. One delay for the whole window
/// (as [`analyse_window`]) matches one beat and cancels another whose interval differed by
/// a fifth of a period: on the fast, irregular family, a fifth of the sliding time went in
/// windows too weak to fix, and none with the interval variability taken out of the same
/// scenes (docs/tracker-beatslide.md, "Beat by beat"). Here each beat's delay is found on
/// its own period (the same matched filter as the window's), the pulse's phase is warped
/// through those beats, and the whole window is fitted once at the warped phase: the
/// amplitudes, their errors and the kernel then follow as for one delay. Needs two beats;
/// `late_s` is the last beat's delay (the clock follows the newest beat).
#[allow(clippy::too_many_arguments)]
pub fn analyse_window_beat_by_beat(
    window: &Window<'_>,
    phase: PulsePhase,
    template: &Waveform,
    prior: SpatialPrior,
    max_delay_fraction: f64,
    configured_noise_sd_n: f64,
    geometry: &ArrayGeometry,
    noise: &mut NoiseLevel,
) -> Result<BeatFix, BeatMiss> {
    use std::f64::consts::TAU;
    let (Some(t0), Some(t1), Some(_)) =
        (window.first_t_s(), window.last_t_s(), window.mean_sensor())
    else {
        return Err(BeatMiss::Empty);
    };
    if !(phase.period_s.is_finite() && phase.period_s > 0.0) {
        return Err(HarmonicFitError::BadPeriod {
            period_s: phase.period_s,
        }
        .into());
    }
    let period = phase.period_s;
    let weights = spatial_weights(prior, geometry);
    let max_delay = max_delay_fraction.clamp(0.0, 0.5) * TAU;
    // Each beat is timed over the period centred on its fundamental's peak.
    let centre = fundamental_delay_rad(template);
    let k_first = ((phase.phase_rad(t0) - centre) / TAU).floor() as i64;
    let k_last = ((phase.phase_rad(t1) - centre) / TAU).ceil() as i64;
    if k_last.saturating_sub(k_first) >= MAX_TIMED_BEATS as i64 {
        return Err(BeatMiss::Empty);
    }
    // (time, warped phase) at each timed beat's centre.
    let mut knots = [(0.0, 0.0); MAX_TIMED_BEATS];
    let mut n = 0;
    let mut previous: Option<f64> = None;
    for k in k_first..=k_last {
        let phi = TAU * k as f64 + centre;
        let tc = phase.t_ref_s + phi / phase.omega_rad_s();
        let (a, b) = (tc - 0.5 * period, tc + 0.5 * period);
        if (b.min(t1) - a.max(t0)) < MIN_BEAT_COVER * period {
            continue;
        }
        let beat = window.frames().filter(|f| f.t_s >= a && f.t_s < b);
        let Ok(fit) = HarmonicFit::fit(beat, phase, Trend::Linear) else {
            continue;
        };
        let combined = fit.combine(&weights);
        // The first beat anywhere in its period (the clock may have drifted a long way
        // while no window gave a fix); each next one within the usual delay of the one
        // before (an interval's change), so that the chain cannot skip or repeat a beat.
        let delay = match previous {
            None => best_delay(
                |q| combined_score(&fit, &combined, q),
                template,
                std::f64::consts::PI,
            ),
            Some(p) => {
                p + best_delay(
                    |q| combined_score(&fit, &combined, q),
                    &shift_waveform(template, p),
                    max_delay,
                )
            }
        };
        previous = Some(delay);
        knots[n] = (tc, phi - delay);
        n += 1;
    }
    if n < 2 {
        return Err(BeatMiss::NoInformation);
    }
    let knots = &knots[..n];
    let omega = phase.omega_rad_s();
    // Piecewise linear through the knots, at the clock's rate beyond them.
    let warped = |t: f64| {
        let (first, last) = (knots[0], knots[n - 1]);
        if t <= first.0 {
            return first.1 + omega * (t - first.0);
        }
        if t >= last.0 {
            return last.1 + omega * (t - last.0);
        }
        let i = knots.partition_point(|k| k.0 <= t).clamp(1, n - 1);
        let (p, q) = (knots[i - 1], knots[i]);
        p.1 + (q.1 - p.1) * (t - p.0) / (q.0 - p.0)
    };
    let fit = HarmonicFit::fit_phase(window.frames(), warped, Trend::Linear)?;
    let sigma = noise
        .estimate(window.frames())
        .unwrap_or(configured_noise_sd_n)
        .max(configured_noise_sd_n);
    let late_s = previous.unwrap_or(0.0) / omega;
    let aligned = fit.combine(&weights);
    fix_at(window, &fit, template, late_s, aligned, sigma, geometry)
}

/// How well the timed waveform `q` matches the spatially combined coefficients `combined`
/// of `fit` (the temporal matched filter, in standard errors).
fn combined_score(fit: &HarmonicFit, combined: &Waveform, q: &Waveform) -> f64 {
    let sq = fit.information * q;
    let norm = q.dot(&sq);
    if norm > 0.0 {
        combined.dot(&sq) / norm.sqrt()
    } else {
        f64::NEG_INFINITY
    }
}

/// How well the timed waveform `q` matches the pulse wherever it lies on the array: the
/// energy of each element's positive matched-filter output about the elements' mean (the
/// mean is the contact's common mode, a pulse pushes its elements up).
fn array_score(fit: &HarmonicFit, q: &Waveform) -> f64 {
    let sq = fit.information * q;
    let norm = q.dot(&sq);
    if norm.is_nan() || norm <= 0.0 {
        return f64::NEG_INFINITY;
    }
    let outputs: [f64; ELEMENTS] = std::array::from_fn(|e| fit.coeffs[e].dot(&sq));
    let mean = outputs.iter().sum::<f64>() / ELEMENTS as f64;
    outputs
        .iter()
        .map(|o| (o - mean).max(0.0).powi(2))
        .sum::<f64>()
        / norm
}

/// The delay, within ±`max_delay` of the fundamental's phase, at which `template` best
/// matches the window by `score` (the temporal matched filter's peak, refined by a parabola
/// through its neighbours).
fn best_delay(score: impl Fn(&Waveform) -> f64, template: &Waveform, max_delay: f64) -> f64 {
    let score = |delay: f64| score(&shift_waveform(template, delay));
    let step = max_delay / DELAY_STEPS as f64;
    let mut best = (f64::NEG_INFINITY, 0i64);
    let steps = DELAY_STEPS as i64;
    for k in -steps..=steps {
        let s = score(k as f64 * step);
        if s > best.0 {
            best = (s, k);
        }
    }
    let mut delay = best.1 as f64 * step;
    if best.1.abs() < steps && step > 0.0 {
        let (lo, mid, hi) = (score(delay - step), best.0, score(delay + step));
        let denom = lo - 2.0 * mid + hi;
        if denom < 0.0 {
            delay += (0.5 * (lo - hi) / denom).clamp(-0.5, 0.5) * step;
        }
    }
    delay
}

/// The kernel at the prior's place, less its mean (the fit's uniform offset absorbs a
/// mean): the weights of the spatial matched filter.
pub fn spatial_weights(prior: SpatialPrior, geometry: &ArrayGeometry) -> [f64; ELEMENTS] {
    let pitch = geometry.pitch_m;
    let mut w: [f64; ELEMENTS] = std::array::from_fn(|e| {
        element_kernel((e as f64 - prior.element) * pitch, prior.width_m, pitch)
    });
    let mean = w.iter().sum::<f64>() / ELEMENTS as f64;
    for v in &mut w {
        *v -= mean;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::SurfacePoint;
    use crate::signal::harmonic::waveform_value;
    use crate::tracker::beatslide::history::History;
    use crate::types::TactileFrame;

    const PERIOD_S: f64 = 0.65;
    const ELEMENT: f64 = 4.3;
    const WIDTH_M: f64 = 0.003;

    fn template() -> Waveform {
        let w = Waveform::from_column_slice(&[0.8, 0.3, 0.35, 0.25, 0.1, 0.12]);
        w / w.norm()
    }

    /// Frames of a pulse whose beats begin at `beats` (s): between two beats the template
    /// runs through one period, whatever the interval. Noise SD 12 mN from a seeded
    /// generator; `amplitude_n` 0 gives noise only.
    fn history(beats: &[f64], amplitude_n: f64, seed: u64) -> History {
        let g = ArrayGeometry::default();
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut h = History::new(1000);
        let dt = 1.0 / g.sample_rate_hz;
        let (t0, t1) = (beats[0], beats[beats.len() - 1]);
        let n = ((t1 - t0) / dt) as usize;
        for i in 0..n {
            let t = t0 + i as f64 * dt;
            let k = beats.partition_point(|&b| b <= t).clamp(1, beats.len() - 1);
            let phi = std::f64::consts::TAU
                * (k as f64 - 1.0 + (t - beats[k - 1]) / (beats[k] - beats[k - 1]));
            let pulse = waveform_value(&template(), phi);
            let force_n = std::array::from_fn(|e| {
                let u = (e as f64 - ELEMENT) * g.pitch_m;
                // Sum of 12 uniforms: close to Gaussian, SD 1.
                let z: f64 = (0..12).map(|_| uniform()).sum::<f64>() - 6.0;
                0.3 + amplitude_n * element_kernel(u, WIDTH_M, g.pitch_m) * pulse + g.noise_sd_n * z
            });
            let frame = TactileFrame {
                t_s: t,
                seq: i as u64,
                force_n,
            };
            h.push(frame, SurfacePoint::new(0.0, 0.0), [1.0, 0.0], None);
        }
        h
    }

    fn clock() -> PulsePhase {
        PulsePhase {
            t_ref_s: 0.0,
            period_s: PERIOD_S,
        }
    }

    fn prior() -> SpatialPrior {
        SpatialPrior {
            element: ELEMENT,
            width_m: WIDTH_M,
        }
    }

    fn both(h: &History) -> (Result<BeatFix, BeatMiss>, Result<BeatFix, BeatMiss>) {
        let g = ArrayGeometry::default();
        let mut noise = NoiseLevel::new(1000);
        let w = h.since(f64::NEG_INFINITY);
        let one = analyse_window(
            &w,
            clock(),
            &template(),
            prior(),
            0.25,
            0.012,
            &g,
            &mut noise,
        );
        let each = analyse_window_beat_by_beat(
            &w,
            clock(),
            &template(),
            prior(),
            0.25,
            0.012,
            &g,
            &mut noise,
        );
        (one, each)
    }

    /// `fix` holds the pulse at its element with more than `factor` times the SNR of
    /// `other` (a fix that lost it, or none).
    fn assert_recovers(fix: &BeatFix, other: &Result<BeatFix, BeatMiss>, factor: f64) {
        let other_snr = other.as_ref().map_or(0.0, |f| f.kernel.snr());
        assert!(
            fix.kernel.snr() > factor * other_snr,
            "SNR {} against {other_snr}",
            fix.kernel.snr()
        );
        assert!(
            (fix.kernel.element - ELEMENT).abs() < 0.3,
            "element {}",
            fix.kernel.element
        );
    }

    /// Beats at the clock's times, each moved by `late` of a period.
    fn beats(late: &[f64]) -> Vec<f64> {
        late.iter()
            .enumerate()
            .map(|(k, l)| (k as f64 + l) * PERIOD_S)
            .collect()
    }

    #[test]
    fn an_irregular_hearts_beats_timed_each_on_its_own_keep_the_pulse_one_delay_loses() {
        // Intervals of 0.65 s ± 25-30 % over about two beats (a sliding window).
        let h = history(&beats(&[0.0, 1.3, 2.05, 3.0]), 0.02, 7);
        let (one, each) = both(&h);
        assert_recovers(&each.expect("beat by beat fits"), &one, 1.3);
    }

    #[test]
    fn a_regular_hearts_window_gives_the_same_fix_either_way() {
        let h = history(&beats(&[0.1, 1.1, 2.1, 3.1]), 0.02, 11);
        let (one, each) = both(&h);
        let (one, each) = (one.expect("one delay"), each.expect("beat by beat"));
        assert!((one.kernel.element - each.kernel.element).abs() < 0.1);
        let ratio = each.kernel.snr() / one.kernel.snr();
        // The free timing fits a little noise too: the statistic rises a little.
        assert!((0.9..1.3).contains(&ratio), "SNR ratio {ratio}");
    }

    /// Of 300 noise-only windows with beats at `late` (see [`beats`]), how many fixes by
    /// `snr_of` reach an SNR of 5 (`fix_snr`), and the largest SNR.
    fn noise_only_passes(
        late: &[f64],
        seed0: u64,
        snr_of: impl Fn(&History) -> Option<f64>,
    ) -> (usize, f64) {
        let mut passed = 0;
        let mut worst: f64 = 0.0;
        for seed in 0..300 {
            if let Some(snr) = snr_of(&history(&beats(late), 0.0, seed0 + seed)) {
                worst = worst.max(snr);
                passed += usize::from(snr >= 5.0);
            }
        }
        (passed, worst)
    }

    #[test]
    fn noise_alone_rarely_passes_the_fix_threshold_when_timed_beat_by_beat() {
        // The free timing of each beat raises the noise-only statistic.
        let (passed, worst) = noise_only_passes(&[0.0, 1.2, 1.9, 3.1, 4.0], 1000, |h| {
            both(h).1.ok().map(|f| f.kernel.snr())
        });
        assert!(passed <= 3, "{passed} of 300 passed (largest SNR {worst})");
    }

    /// The window analysed with the prior at `element`: timed there, and on the array.
    fn prior_and_array(
        h: &History,
        element: f64,
    ) -> (Result<BeatFix, BeatMiss>, Result<BeatFix, BeatMiss>) {
        let g = ArrayGeometry::default();
        let mut noise = NoiseLevel::new(1000);
        let w = h.since(f64::NEG_INFINITY);
        let prior = SpatialPrior {
            element,
            width_m: WIDTH_M,
        };
        let at_prior = analyse_window(&w, clock(), &template(), prior, 0.25, 0.012, &g, &mut noise);
        let on_array =
            analyse_window_on_array(&w, clock(), &template(), prior, 0.25, 0.012, &g, &mut noise);
        (at_prior, on_array)
    }

    #[test]
    fn a_pulse_the_artery_carried_away_from_the_prior_is_timed_on_the_array() {
        // Two beats 0.1 period late; the last fix put the artery 4 elements (8 mm) away.
        let late = 0.1;
        let h = history(&beats(&[late, 1.0 + late, 2.0 + late]), 0.03, 5);
        let (at_prior, on_array) = prior_and_array(&h, ELEMENT + 4.0);
        let on_array = on_array.expect("timed on the array");
        assert_recovers(&on_array, &at_prior, 2.0);
        // Timed as if the prior had been right, and the template learns from the pulse
        // where it was found, not from the prior's elements.
        let right = prior_and_array(&h, ELEMENT).0.expect("at the right prior");
        assert!(
            (on_array.late_s - right.late_s).abs() < 0.01,
            "late {} s on the array, {} s at the right prior",
            on_array.late_s,
            right.late_s
        );
        let cos =
            on_array.aligned.dot(&right.aligned) / (on_array.aligned.norm() * right.aligned.norm());
        assert!(cos > 0.95, "learned waveforms at {cos}");
    }

    #[test]
    fn where_the_prior_is_right_the_array_gives_the_same_fix() {
        let h = history(&beats(&[0.05, 1.05, 2.05]), 0.03, 9);
        let (at_prior, on_array) = prior_and_array(&h, ELEMENT);
        let (a, b) = (
            at_prior.expect("at the prior"),
            on_array.expect("on the array"),
        );
        assert!((a.kernel.element - b.kernel.element).abs() < 0.1);
        assert!((a.late_s - b.late_s).abs() < 0.01);
        let ratio = b.kernel.snr() / a.kernel.snr();
        assert!((0.95..1.05).contains(&ratio), "SNR ratio {ratio}");
    }

    #[test]
    fn noise_alone_rarely_passes_the_fix_threshold_when_timed_on_the_array() {
        // Timed on whichever element's noise is largest, the statistic rises; the sliding
        // tracker asks twice `fix_snr` of a fix timed so.
        let (passed, worst) = noise_only_passes(&[0.0, 1.0, 2.0], 5000, |h| {
            prior_and_array(h, ELEMENT).1.ok().map(|f| f.kernel.snr())
        });
        assert!(passed <= 3, "{passed} of 300 passed (largest SNR {worst})");
    }

    #[test]
    fn one_beat_is_not_timed_beat_by_beat() {
        let h = history(&beats(&[0.0, 1.0]), 0.06, 3);
        let (_, each) = both(&h);
        assert!(matches!(each, Err(BeatMiss::NoInformation)), "{each:?}");
    }
}
