//! The path model's motion modes as estimates in one frame: each mode's state and
//! covariance, the Kalman step they share, and the interacting multiple model's arithmetic
//! (mixing before a step, weighing by the fix's likelihood after it, merging for what the
//! tracker reads). The frame and what a state means are the path filter's
//! (`path_filter.rs`); here they are only vectors.

use nalgebra::{Matrix4, Vector4};

/// One mode's estimate: state and covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Mode {
    pub x: Vector4<f64>,
    pub p: Matrix4<f64>,
}

impl Mode {
    /// The Kalman update for one scalar reading `z = h·x` with SD `sd_m`.
    pub fn measure_along(&mut self, h: Vector4<f64>, z: f64, sd_m: f64) {
        let ph = self.p * h;
        let var = h.dot(&ph) + sd_m * sd_m;
        if !(var.is_finite() && var > 0.0) {
            return;
        }
        let k = ph / var;
        self.x += k * (z - h.dot(&self.x));
        // Joseph form keeps P symmetric and positive.
        let ikh = Matrix4::identity() - k * h.transpose();
        self.p = ikh * self.p * ikh.transpose() + k * k.transpose() * (sd_m * sd_m);
    }

    /// Drop the lag's (index 3) correlation with the path.
    pub fn decouple_lag(&mut self) {
        for i in 0..3 {
            self.p[(i, 3)] = 0.0;
            self.p[(3, i)] = 0.0;
        }
    }
}

/// The Gaussian closest to a mixture of modes (mean, and covariance with the spread of the
/// means), weights summing to one.
pub(super) fn merge(modes: &[Mode; 2], weights: [f64; 2]) -> Mode {
    let x = modes[0].x * weights[0] + modes[1].x * weights[1];
    let mut p = Matrix4::zeros();
    for (m, w) in modes.iter().zip(weights) {
        let spread = m.x - x;
        p += (m.p + spread * spread.transpose()) * w;
    }
    Mode { x, p }
}

/// `transition[i][j]`: probability that mode `i` becomes mode `j` by the next fix.
pub(super) type Transition = [[f64; 2]; 2];

/// The modes' probabilities at the next fix, from those after the last.
pub(super) fn predicted_weights(weights: [f64; 2], transition: &Transition) -> [f64; 2] {
    let mut next = [0.0; 2];
    for (i, w) in weights.iter().enumerate() {
        for (j, n) in next.iter_mut().enumerate() {
            *n += transition[i][j] * w;
        }
    }
    next
}

/// Each mode's starting estimate for the next step: the modes mixed by how likely each is
/// to have become it (the interacting multiple model's first step). A mode nothing leads
/// to keeps its own.
pub(super) fn mixed(modes: &[Mode; 2], weights: [f64; 2], transition: &Transition) -> [Mode; 2] {
    let next = predicted_weights(weights, transition);
    let mut out = *modes;
    for (j, o) in out.iter_mut().enumerate() {
        if next[j] > 0.0 {
            let given = [
                transition[0][j] * weights[0] / next[j],
                transition[1][j] * weights[1] / next[j],
            ];
            *o = merge(modes, given);
        }
    }
    out
}

/// The modes' probabilities after a fix from their prior and, per mode, the fix's
/// innovation and its variance: Bayes with Gaussian likelihoods, in logs so that a fix far
/// out in both does not underflow to 0/0. Unusable likelihoods leave the prior.
pub(super) fn posterior(prior: [f64; 2], innovations: [f64; 2], vars: [f64; 2]) -> [f64; 2] {
    let log = |k: usize| {
        prior[k].max(1e-300).ln() - 0.5 * (vars[k].ln() + innovations[k] * innovations[k] / vars[k])
    };
    let (l0, l1) = (log(0), log(1));
    if !(l0.is_finite() && l1.is_finite()) {
        return prior;
    }
    let top = l0.max(l1);
    let (w0, w1) = ((l0 - top).exp(), (l1 - top).exp());
    [w0 / (w0 + w1), w1 / (w0 + w1)]
}
