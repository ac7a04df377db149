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
//! The point is reported at the mean believed sensor position over the window: the
//! localization averages the window, and the sensor slides along the artery, so the
//! artery's place on the array changes little within it.

use crate::frames::SurfacePoint;
use crate::sensor::ArrayGeometry;
use crate::signal::harmonic::{
    HarmonicFit, HarmonicFitError, PulsePhase, Trend, Waveform, shift_waveform,
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
    let (Some(t0), Some(t1), Some(sensor)) =
        (window.first_t_s(), window.last_t_s(), window.mean_sensor())
    else {
        return Err(BeatMiss::Empty);
    };
    let fit = HarmonicFit::fit(window.frames(), phase, Trend::Linear)?;
    let sigma = noise
        .estimate(window.frames())
        .unwrap_or(configured_noise_sd_n)
        .max(configured_noise_sd_n);
    let weights = spatial_weights(prior, geometry);
    let combined = fit.combine(&weights);
    let max_delay = max_delay_fraction.clamp(0.0, 0.5) * std::f64::consts::TAU;
    let score = |delay: f64| {
        let q = shift_waveform(template, delay);
        let sq = fit.information * q;
        let norm = q.dot(&sq);
        if norm > 0.0 {
            combined.dot(&sq) / norm.sqrt()
        } else {
            f64::NEG_INFINITY
        }
    };
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
    let q = shift_waveform(template, delay);
    let projection = fit.project(&q).ok_or(BeatMiss::NoInformation)?;
    let kernel = fit_kernel(
        &projection.amplitude_n,
        projection.se_per_sigma * sigma,
        geometry,
    )?;
    Ok(BeatFix {
        t_mid_s: 0.5 * (t0 + t1),
        late_s: delay / phase.omega_rad_s(),
        kernel,
        sensor,
        lag_dir: window.mean_lag(),
        felt_offset: window.mean_felt_offset(),
        noise_sd_n: sigma,
        aligned: shift_waveform(&combined, -delay),
    })
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
