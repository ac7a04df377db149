//! Where the felt pulse lies: the kernel family fitted to each element's summed correlation
//! along the pulse's track, with its Cramér-Rao standard error.
//!
//! Along a track of template energy `E`, element `e`'s whitened correlation over `√E` is
//! `z_e = a √E s_e(x₀)/σ_e + n_e`, `n_e` independent unit normals: the same form as the
//! ideal detector's statistic in `detection_bound`. The amplitude is free, so the position
//! is the one whose whitened kernel `v(x) = s(x)/σ` best projects `z`, found on a grid of a
//! hundredth of a pitch and refined by a parabola; its standard error is
//! `1/√(ĉ² (‖v'‖² − ⟨v, v'⟩²/‖v‖²))` with `ĉ` the fitted amplitude (the bound's formula at
//! the estimate).

use super::super::kernel_fit::element_kernel;
use crate::types::ELEMENTS;

#[derive(Clone)]
pub(super) struct SpatialKernel {
    pub pitch_m: f64,
    pub width_m: f64,
}

impl SpatialKernel {
    /// Force per unit amplitude on each element with the artery at `x_m` along the array
    /// (0 at its middle, element order).
    pub(super) fn at(&self, x_m: f64) -> [f64; ELEMENTS] {
        let middle = (ELEMENTS as f64 - 1.0) / 2.0;
        std::array::from_fn(|e| {
            element_kernel(
                (e as f64 - middle) * self.pitch_m - x_m,
                self.width_m,
                self.pitch_m,
            )
        })
    }

    /// `v(x) = s(x)/σ` with elements of zero weight left out.
    pub(super) fn whitened(&self, x_m: f64, inverse_sd: &[f64; ELEMENTS]) -> [f64; ELEMENTS] {
        let s = self.at(x_m);
        std::array::from_fn(|e| s[e] * inverse_sd[e])
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Placed {
    pub x_m: f64,
    pub se_m: f64,
    pub at_edge: bool,
    /// The fitted amplitude `ĉ` (`a √E`).
    pub amplitude: f64,
}

/// The best position in `[-half_range, half_range]` for `z`, or `None` if no positive
/// amplitude fits anywhere.
pub(super) fn place(
    kernel: &SpatialKernel,
    z: &[f64; ELEMENTS],
    inverse_sd: &[f64; ELEMENTS],
    half_range_m: f64,
) -> Option<Placed> {
    let step = kernel.pitch_m / 100.0;
    let n = (2.0 * half_range_m / step).round() as usize;
    let x_at = |i: usize| -half_range_m + i as f64 * step;
    let projection = |x: f64| {
        let v = kernel.whitened(x, inverse_sd);
        let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if norm > 0.0 {
            v.iter().zip(z).map(|(a, b)| a * b).sum::<f64>() / norm
        } else {
            f64::NEG_INFINITY
        }
    };
    let values: Vec<f64> = (0..=n).map(|i| projection(x_at(i))).collect();
    let (best, top) =
        values.iter().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |a, (i, &v)| if v > a.1 { (i, v) } else { a },
        );
    if top.is_nan() || top <= 0.0 {
        return None;
    }
    let at_edge = best == 0 || best == n;
    let mut x = x_at(best);
    if !at_edge {
        let (a, b, c) = (values[best - 1], values[best], values[best + 1]);
        let curvature = a - 2.0 * b + c;
        if curvature < 0.0 {
            x += 0.5 * step * (a - c) / curvature;
        }
    }
    let v = kernel.whitened(x, inverse_sd);
    let (up, down) = (
        kernel.whitened(x + step, inverse_sd),
        kernel.whitened(x - step, inverse_sd),
    );
    let dv: [f64; ELEMENTS] = std::array::from_fn(|e| (up[e] - down[e]) / (2.0 * step));
    let vv: f64 = v.iter().map(|a| a * a).sum();
    let vd: f64 = v.iter().zip(&dv).map(|(a, b)| a * b).sum();
    let dd: f64 = dv.iter().map(|a| a * a).sum();
    let amplitude = v.iter().zip(z).map(|(a, b)| a * b).sum::<f64>() / vv;
    let information = amplitude * amplitude * (dd - vd * vd / vv);
    let se_m = if at_edge || information.is_nan() || information <= 0.0 {
        f64::INFINITY
    } else {
        1.0 / information.sqrt()
    };
    Some(Placed {
        x_m: x,
        se_m,
        at_edge,
        amplitude,
    })
}
