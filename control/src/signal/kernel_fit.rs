//! Sub-element localization: fit the pulsing tube's pressure kernel to the ten elements'
//! pulse amplitudes.
//!
//! A tube at depth `h` under a flat contact presses the surface with
//! `p(u) ∝ (h² − u²) / (u² + h²)²` at lateral distance `u` (DESIGN.md section 5): positive over
//! the tube, negative beyond `|u| = h`. Over an element of width `b` centred at `u` it
//! integrates to `G(u + b/2) − G(u − b/2)` with `G(u) = u / (u² + w²)`. The model of the
//! amplitudes `a_e` is
//!
//! ```text
//! a_e = α k(ξ_e − ξ₀; w) + β
//! ```
//!
//! with `k` that integral normalized to 1 at its peak, `ξ_e` the element's position along
//! the array, `ξ₀` the artery's, `w` the kernel's width (the depth, stretched by
//! `1/sin` of the crossing angle when the artery crosses the element line obliquely), `α > 0`
//! the amplitude and `β` a uniform offset (a rigid sensor body takes back the kernel's net
//! force uniformly). `α` and `β` are linear; `ξ₀` and `w` are searched on a grid (with
//! `α`, `β` solved at each point), then all four refined together by Levenberg–Marquardt;
//! standard errors come from `σ² (JᵀJ)⁻¹`. The far elements' negative lobe is part of the model,
//! so an artery at the array's edge is still placed from the flank the array does see; the
//! search extends one pitch beyond each end and a minimum there is flagged `at_edge`.
//!
//! The same fit serves other symmetric kernels (the width absorbs their scale): it is a
//! matched template, not a claim that the tissue is a half-space.

use crate::sensor::{ArrayGeometry, MIN_TRUSTED_ELEMENTS};
use crate::types::ELEMENTS;

/// Kernel widths searched, m (depths of 1.5–16 mm, or shallower arteries crossing obliquely).
const WIDTHS_M: [f64; 12] = [
    0.0015, 0.002, 0.0025, 0.003, 0.0035, 0.004, 0.005, 0.006, 0.0075, 0.009, 0.012, 0.016,
];

/// Grid step of the artery position, in pitches.
const GRID_STEP_PITCH: f64 = 0.125;

/// How far beyond the outer elements the artery is searched, in pitches.
const MARGIN_PITCH: f64 = 1.0;

/// The fitted artery.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelFit {
    /// Lateral offset of the artery from the sensor centre along tissue `z`, m.
    pub offset_z_m: f64,
    /// The same as a (fractional) element index.
    pub element: f64,
    /// Its standard error, m (infinite when the fit cannot place it).
    pub offset_se_m: f64,
    /// Pulse amplitude at the kernel's peak, N (per unit of the input's scale).
    pub amplitude: f64,
    pub amplitude_se: f64,
    /// Uniform offset β.
    pub baseline: f64,
    /// Kernel width w, m.
    pub width_m: f64,
    /// Sum of squared residuals over the amplitudes' variance (χ² with the trusted elements
    /// less 4 degrees of freedom for a good fit).
    pub chi2: f64,
    /// The best position lies at the end of the searched range: the artery is at or beyond
    /// the array's edge and `offset_z_m` is only a bound.
    pub at_edge: bool,
}

impl KernelFit {
    /// Amplitude over its standard error: the detection statistic.
    pub fn snr(&self) -> f64 {
        if self.amplitude_se > 0.0 {
            self.amplitude / self.amplitude_se
        } else {
            0.0
        }
    }
}

/// Why no artery could be fitted.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum KernelFitError {
    #[error("the amplitudes are not finite")]
    NonFinite,
    #[error("the amplitude noise {0} is not positive and finite")]
    BadNoise(f64),
    #[error("no positive kernel fits the amplitudes")]
    NoPositivePeak,
    #[error("only {0} trusted elements; the fit needs {MIN_TRUSTED_ELEMENTS}")]
    TooFewElements(usize),
}

/// The element-integrated kernel at offset `u` (m) for width `w` and element width `b`,
/// normalized to 1 at `u = 0`.
pub fn element_kernel(u: f64, w: f64, b: f64) -> f64 {
    let g = |x: f64| x / (x * x + w * w);
    let peak = 2.0 * g(0.5 * b);
    (g(u + 0.5 * b) - g(u - 0.5 * b)) / peak
}

/// Fit the kernel to `amplitudes` (one per element, element 0 first), each with noise SD
/// `noise` (same units). Positions come from `geometry` (pitch and direction).
pub fn fit_kernel(
    amplitudes: &[f64; ELEMENTS],
    noise: f64,
    geometry: &ArrayGeometry,
) -> Result<KernelFit, KernelFitError> {
    if amplitudes.iter().any(|a| !a.is_finite()) {
        return Err(KernelFitError::NonFinite);
    }
    if !(noise.is_finite() && noise > 0.0) {
        return Err(KernelFitError::BadNoise(noise));
    }
    let pitch = geometry.pitch_m;
    let middle = (ELEMENTS as f64 - 1.0) / 2.0;
    let xi: [f64; ELEMENTS] = std::array::from_fn(|e| (e as f64 - middle) * pitch);
    // Skipped elements weigh nothing: the fit sees only the trusted ones.
    let wt = geometry.skip_elements.weights();
    let n = wt.iter().sum::<f64>();
    if n < MIN_TRUSTED_ELEMENTS as f64 {
        return Err(KernelFitError::TooFewElements(n as usize));
    }
    let mean_a = (0..ELEMENTS).map(|e| wt[e] * amplitudes[e]).sum::<f64>() / n;
    let total_ss: f64 = (0..ELEMENTS)
        .map(|e| wt[e] * (amplitudes[e] - mean_a).powi(2))
        .sum();
    // No variation across the array (far below the noise): nothing to place.
    if total_ss <= 1e-20 * noise * noise {
        return Err(KernelFitError::NoPositivePeak);
    }
    let half_range = middle + MARGIN_PITCH;
    let steps = (2.0 * half_range / GRID_STEP_PITCH).round() as usize;
    let step_m = 2.0 * half_range * pitch / steps as f64;
    let position = |i: usize| -half_range * pitch + i as f64 * step_m;

    let mut best: Option<(f64, usize, usize)> = None; // (sse, position index, width index)
    for (wi, &w) in WIDTHS_M.iter().enumerate() {
        for i in 0..=steps {
            if let Some((sse, _, _)) = profile(amplitudes, &wt, &xi, position(i), w, pitch, mean_a)
                && best.is_none_or(|(b, _, _)| sse < b)
            {
                best = Some((sse, i, wi));
            }
        }
    }
    let (_, i0, wi) = best.ok_or(KernelFitError::NoPositivePeak)?;
    let x0 = position(i0);
    let (_, alpha0, beta0) = profile(amplitudes, &wt, &xi, x0, WIDTHS_M[wi], pitch, mean_a)
        .ok_or(KernelFitError::NoPositivePeak)?;
    let limit = half_range * pitch;
    let start = [x0, WIDTHS_M[wi].ln(), alpha0, beta0];
    let (theta, information) = refine(amplitudes, &wt, &xi, pitch, start, limit);
    let variance = noise * noise;
    let sse: f64 = (0..ELEMENTS)
        .map(|e| wt[e] * (amplitudes[e] - model(&theta, xi[e], pitch)).powi(2))
        .sum();
    let at_edge = theta[0].abs() >= limit - 1e-9;
    let covariance = information.try_inverse();
    let se = |k: usize| {
        covariance
            .map(|c| c[(k, k)])
            .filter(|v| v.is_finite() && *v > 0.0)
            .map_or(f64::INFINITY, |v| (v * variance).sqrt())
    };
    Ok(KernelFit {
        offset_z_m: geometry.direction * theta[0],
        element: middle + theta[0] / pitch,
        offset_se_m: if at_edge { f64::INFINITY } else { se(0) },
        amplitude: theta[2],
        amplitude_se: se(2),
        baseline: theta[3],
        width_m: theta[1].exp(),
        chi2: sse / variance,
        at_edge,
    })
}

/// Parameters: position ξ₀ (m), ln w, α, β.
type Params = [f64; 4];

fn model(th: &Params, xi: f64, pitch: f64) -> f64 {
    th[2] * element_kernel(xi - th[0], th[1].exp(), pitch) + th[3]
}

/// Levenberg–Marquardt from the grid's best point, keeping α positive, the width within
/// the searched range and the position within `limit`. Returns the parameters and `JᵀJ`.
fn refine(
    a: &[f64; ELEMENTS],
    wt: &[f64; ELEMENTS],
    xi: &[f64; ELEMENTS],
    pitch: f64,
    start: Params,
    limit: f64,
) -> (Params, nalgebra::Matrix4<f64>) {
    let (ln_w_lo, ln_w_hi) = (WIDTHS_M[0].ln(), WIDTHS_M[WIDTHS_M.len() - 1].ln());
    let sse = |th: &Params| -> f64 {
        (0..ELEMENTS)
            .map(|e| wt[e] * (a[e] - model(th, xi[e], pitch)).powi(2))
            .sum()
    };
    let jacobian = |th: &Params| -> (nalgebra::Matrix4<f64>, nalgebra::Vector4<f64>) {
        let mut jtj = nalgebra::Matrix4::zeros();
        let mut jtr = nalgebra::Vector4::zeros();
        let steps = [1e-7, 1e-5];
        for e in 0..ELEMENTS {
            let mut row = nalgebra::Vector4::zeros();
            for (p, h) in steps.iter().enumerate() {
                let (mut up, mut down) = (*th, *th);
                up[p] += h;
                down[p] -= h;
                row[p] = (model(&up, xi[e], pitch) - model(&down, xi[e], pitch)) / (2.0 * h);
            }
            row[2] = element_kernel(xi[e] - th[0], th[1].exp(), pitch);
            row[3] = 1.0;
            let r = a[e] - model(th, xi[e], pitch);
            jtj += row * row.transpose() * wt[e];
            jtr += row * (r * wt[e]);
        }
        (jtj, jtr)
    };
    let mut th = start;
    let mut current = sse(&th);
    let mut lambda = 1e-3;
    for _ in 0..50 {
        let (jtj, jtr) = jacobian(&th);
        let mut improved = false;
        for _ in 0..12 {
            let mut damped = jtj;
            for k in 0..4 {
                damped[(k, k)] *= 1.0 + lambda;
                damped[(k, k)] += 1e-30;
            }
            let Some(step) = damped.lu().solve(&jtr) else {
                lambda *= 10.0;
                continue;
            };
            let candidate = [
                (th[0] + step[0]).clamp(-limit, limit),
                (th[1] + step[1]).clamp(ln_w_lo, ln_w_hi),
                th[2] + step[2],
                th[3] + step[3],
            ];
            let value = sse(&candidate);
            if candidate[2] > 0.0 && value.is_finite() && value < current {
                let gain = current - value;
                th = candidate;
                current = value;
                lambda = (lambda / 3.0).max(1e-9);
                improved = gain > 1e-14 * (1.0 + current);
                break;
            }
            lambda *= 4.0;
        }
        if !improved {
            break;
        }
    }
    (th, jacobian(&th).0)
}

/// The least-squares α, β for the kernel at `x0` and its sum of squared residuals; `None`
/// unless α is positive.
fn profile(
    a: &[f64; ELEMENTS],
    wt: &[f64; ELEMENTS],
    xi: &[f64; ELEMENTS],
    x0: f64,
    w: f64,
    pitch: f64,
    mean_a: f64,
) -> Option<(f64, f64, f64)> {
    let k: [f64; ELEMENTS] = std::array::from_fn(|e| element_kernel(xi[e] - x0, w, pitch));
    let n = wt.iter().sum::<f64>();
    let mean_k = (0..ELEMENTS).map(|e| wt[e] * k[e]).sum::<f64>() / n;
    let (mut skk, mut ska, mut saa) = (0.0, 0.0, 0.0);
    for e in 0..ELEMENTS {
        let (dk, da) = (k[e] - mean_k, a[e] - mean_a);
        skk += wt[e] * dk * dk;
        ska += wt[e] * dk * da;
        saa += wt[e] * da * da;
    }
    if skk <= 0.0 {
        return None;
    }
    let alpha = ska / skk;
    if alpha.is_nan() || alpha <= 0.0 {
        return None;
    }
    let sse = (saa - alpha * ska).max(0.0);
    Some((sse, alpha, mean_a - alpha * mean_k))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::ElementMask;

    fn geometry() -> ArrayGeometry {
        ArrayGeometry::default()
    }

    fn synth(x0: f64, w: f64, alpha: f64, beta: f64) -> [f64; ELEMENTS] {
        let p = 0.002;
        std::array::from_fn(|e| alpha * element_kernel((e as f64 - 4.5) * p - x0, w, p) + beta)
    }

    #[test]
    fn kernel_peaks_at_one_and_goes_negative_beyond_the_depth() {
        let (w, b) = (0.005, 0.002);
        assert!((element_kernel(0.0, w, b) - 1.0).abs() < 1e-15);
        assert!(element_kernel(0.004, w, b) > 0.0);
        assert!(element_kernel(0.007, w, b) < 0.0);
        assert!((element_kernel(0.003, w, b) - element_kernel(-0.003, w, b)).abs() < 1e-15);
    }

    #[test]
    fn places_the_artery_between_elements_exactly_without_noise() {
        for &x0 in &[-0.0081, -0.004, -0.001, 0.0, 0.0007, 0.0033, 0.0089] {
            for &w in &[0.003, 0.005, 0.0085] {
                let a = synth(x0, w, 0.06, -0.01);
                let f = fit_kernel(&a, 0.001, &geometry()).expect("fits");
                assert!(
                    (f.offset_z_m - x0).abs() < 0.05e-3,
                    "x0 {x0} w {w}: got {}",
                    f.offset_z_m
                );
                assert!(!f.at_edge);
                assert!(
                    (f.amplitude - 0.06).abs() < 0.01 * 0.06 + 0.004,
                    "{}",
                    f.amplitude
                );
                let element = geometry().element_at(x0);
                assert!((f.element - element).abs() < 0.03);
            }
        }
    }

    #[test]
    fn a_skipped_element_is_left_out_of_the_fit() {
        // Element 5 is dead (reads nothing) right beside the artery at element 4.25.
        let x0 = geometry().offset_z_m(4.25);
        let mut a = synth(x0, 0.005, 0.06, 0.0);
        a[5] = 0.0;
        let trusting = fit_kernel(&a, 0.001, &geometry()).expect("fits");
        let skipping = ArrayGeometry {
            skip_elements: ElementMask::try_from(vec![5]).unwrap(),
            ..geometry()
        };
        let f = fit_kernel(&a, 0.001, &skipping).expect("fits");
        assert!((f.offset_z_m - x0).abs() < 0.05e-3, "{f:?}");
        assert!((f.amplitude - 0.06).abs() < 0.004, "{f:?}");
        // Trusted, the dead element drags the artery away from itself and spoils the fit.
        assert!(trusting.offset_z_m - x0 < -0.2e-3, "{trusting:?}");
        assert!(
            trusting.chi2 > 100.0 * f.chi2.max(1e-3),
            "{trusting:?} vs {f:?}"
        );
        // Whatever a skipped element reads does not matter.
        for junk in [-5.0, 0.3, 1e6] {
            a[5] = junk;
            let g = fit_kernel(&a, 0.001, &skipping).expect("fits");
            assert!((g.offset_z_m - f.offset_z_m).abs() < 1e-9, "{junk}: {g:?}");
        }
        // Five trusted elements are too few for a four-parameter fit to be checked.
        let five = ArrayGeometry {
            skip_elements: ElementMask::try_from(vec![0, 1, 2, 3, 9]).unwrap(),
            ..geometry()
        };
        assert_eq!(
            fit_kernel(&a, 0.001, &five),
            Err(KernelFitError::TooFewElements(5))
        );
    }

    #[test]
    fn an_artery_beyond_the_edge_is_flagged() {
        // 4 mm beyond element 9: the array sees the flank and the negative lobe only.
        let a = synth(0.013, 0.005, 0.06, 0.0);
        let f = fit_kernel(&a, 0.001, &geometry()).expect("the flank still fits");
        assert!(f.at_edge, "{f:?}");
        assert!(f.offset_z_m > 0.0095);
        assert!(f.offset_se_m.is_infinite());
        // On the outer element itself it is still placed.
        let a = synth(0.009, 0.005, 0.06, 0.0);
        let f = fit_kernel(&a, 0.001, &geometry()).expect("fits");
        assert!(!f.at_edge && (f.offset_z_m - 0.009).abs() < 0.1e-3, "{f:?}");
    }

    #[test]
    fn follows_the_element_direction() {
        let flipped = ArrayGeometry {
            direction: -1.0,
            ..geometry()
        };
        let a = synth(0.003, 0.005, 0.05, 0.0);
        let f = fit_kernel(&a, 0.001, &flipped).expect("fits");
        assert!((f.offset_z_m + 0.003).abs() < 0.05e-3);
    }

    #[test]
    fn flat_negative_and_bad_inputs() {
        let g = geometry();
        assert_eq!(
            fit_kernel(&[0.0; ELEMENTS], 0.001, &g),
            Err(KernelFitError::NoPositivePeak)
        );
        assert_eq!(
            fit_kernel(&[0.3; ELEMENTS], 0.001, &g),
            Err(KernelFitError::NoPositivePeak)
        );
        // An inverted pulse is not an artery here; the negative lobe alone may fit some far
        // positive kernel, but never one in the middle of the array.
        let neg = synth(0.0, 0.005, -0.06, 0.0);
        if let Ok(f) = fit_kernel(&neg, 0.001, &g) {
            assert!(f.at_edge || f.offset_z_m.abs() > 0.006, "{f:?}");
        }
        let mut nan = [0.0; ELEMENTS];
        nan[4] = f64::NAN;
        assert_eq!(fit_kernel(&nan, 0.001, &g), Err(KernelFitError::NonFinite));
        assert!(matches!(
            fit_kernel(&synth(0.0, 0.005, 0.06, 0.0), 0.0, &g),
            Err(KernelFitError::BadNoise(_))
        ));
    }

    #[test]
    fn standard_error_covers_the_scatter() {
        let g = geometry();
        let mut state = 7u64;
        let mut normal = move || {
            let mut u = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (u().max(1e-300), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let (x0, noise) = (0.0013, 0.004);
        let mut z2 = 0.0;
        let runs = 300;
        for _ in 0..runs {
            let mut a = synth(x0, 0.005, 0.06, -0.005);
            for v in &mut a {
                *v += noise * normal();
            }
            let f = fit_kernel(&a, noise, &g).expect("fits");
            z2 += ((f.offset_z_m - x0) / f.offset_se_m).powi(2);
            assert!(f.snr() > 5.0);
        }
        let rms_z = (z2 / runs as f64).sqrt();
        assert!((0.6..1.6).contains(&rms_z), "normalized scatter {rms_z}");
    }
}
