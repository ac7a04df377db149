//! Stress recovery at the top-edge nodes (the "tactile image" of the papers).
//!
//! Stresses are computed at the 2x2 Gauss points (where Q4 stresses are most accurate),
//! extrapolated bilinearly to the element's nodes, and averaged over the elements that share
//! each top node.

use super::element::extrapolate_to_nodes;
use super::material::von_mises;
use super::mesh::Mesh;

/// Recovered stress (σxx, σyy, σxy, σzz) at each top node, in `mesh.top` order.
pub fn top_stresses(mesh: &Mesh, gauss_stress: impl Fn(usize) -> [[f64; 4]; 4]) -> Vec<[f64; 4]> {
    let mut slot = vec![u32::MAX; mesh.nodes.len()];
    for (i, &n) in mesh.top.iter().enumerate() {
        slot[n as usize] = i as u32;
    }
    let mut sum = vec![[0.0; 4]; mesh.top.len()];
    let mut count = vec![0u32; mesh.top.len()];
    for (e, el) in mesh.elements.iter().enumerate() {
        if !el.iter().any(|&n| slot[n as usize] != u32::MAX) {
            continue;
        }
        let nodal = extrapolate_to_nodes(&gauss_stress(e));
        for (a, &n) in el.iter().enumerate() {
            let s = slot[n as usize];
            if s != u32::MAX {
                for c in 0..4 {
                    sum[s as usize][c] += nodal[a][c];
                }
                count[s as usize] += 1;
            }
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| {
            let c = f64::from(c.max(1));
            [s[0] / c, s[1] / c, s[2] / c, s[3] / c]
        })
        .collect()
}

/// Von Mises of recovered stresses.
pub fn von_mises_of(stresses: &[[f64; 4]]) -> Vec<f64> {
    stresses
        .iter()
        .map(|s| von_mises(s[0], s[1], s[2], s[3]))
        .collect()
}

/// A curve along the top edge: its peak, where it is, and its value at `x0` (linear
/// interpolation). `x` must be sorted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveSummary {
    pub peak: f64,
    pub x_peak: f64,
    pub at_x0: f64,
}

pub fn summarize(x: &[f64], y: &[f64], x0: f64) -> CurveSummary {
    let mut best = (f64::NEG_INFINITY, f64::NAN);
    for (&xi, &yi) in x.iter().zip(y) {
        if yi > best.0 {
            best = (yi, xi);
        }
    }
    CurveSummary {
        peak: best.0,
        x_peak: best.1,
        at_x0: interpolate(x, y, x0),
    }
}

/// Linear interpolation in a sorted table; clamps outside it.
pub fn interpolate(x: &[f64], y: &[f64], at: f64) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let k = x.partition_point(|&v| v < at);
    if k == 0 {
        return y[0];
    }
    if k >= x.len() {
        return y[x.len() - 1];
    }
    let (x0, x1) = (x[k - 1], x[k]);
    let t = if x1 > x0 { (at - x0) / (x1 - x0) } else { 0.0 };
    y[k - 1] + t * (y[k] - y[k - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_and_interpolation() {
        let x = [-1.0, 0.0, 1.0, 2.0];
        let y = [1.0, 3.0, 2.0, 0.0];
        let s = summarize(&x, &y, 0.5);
        assert_eq!(s.peak, 3.0);
        assert_eq!(s.x_peak, 0.0);
        assert!((s.at_x0 - 2.5).abs() < 1e-12);
        assert_eq!(interpolate(&x, &y, -5.0), 1.0);
        assert_eq!(interpolate(&x, &y, 5.0), 0.0);
    }
}
