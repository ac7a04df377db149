//! One segment's detrended samples folded at every trial heart rate, then matched with the
//! pulse template at every phase.
//!
//! The fold's phase is `frac(f t)` with `t` from the stream's start, so a pulse that keeps
//! its rate keeps its phase bin from one segment to the next (the track carries it across
//! rate changes). Folding keeps the memory to `rates × bins × elements` sums whatever the
//! segment's length. Matching at phase `φ` correlates each element's fold with the template
//! shifted to start at bin `φ`, with the template's count-weighted mean removed (so what is
//! left of a static load after detrending cannot correlate), giving `c_e(φ)` and the
//! template's energy `E(φ) = Σ n_b t_b²`: under noise alone `c_e ~ N(0, σ_e² E)`.

use crate::types::ELEMENTS;

#[derive(Clone)]
pub(super) struct Folds {
    rates_hz: Vec<f64>,
    bins: usize,
    /// Per rate: the template over the bins (unit RMS, zero mean).
    templates: Vec<f64>,
    sums: Vec<f64>,
    counts: Vec<f64>,
}

impl Folds {
    pub(super) fn new(rates_hz: Vec<f64>, bins: usize, templates: Vec<f64>) -> Self {
        let j = rates_hz.len();
        Self {
            rates_hz,
            bins,
            templates,
            sums: vec![0.0; j * bins * ELEMENTS],
            counts: vec![0.0; j * bins],
        }
    }

    pub(super) fn add(&mut self, t_rel_s: f64, y: &[f64; ELEMENTS]) {
        let b = self.bins;
        for (j, &f) in self.rates_hz.iter().enumerate() {
            let bin = (((f * t_rel_s).rem_euclid(1.0) * b as f64) as usize).min(b - 1);
            let at = j * b + bin;
            self.counts[at] += 1.0;
            let s = &mut self.sums[at * ELEMENTS..(at + 1) * ELEMENTS];
            for e in 0..ELEMENTS {
                s[e] += y[e];
            }
        }
    }

    pub(super) fn clear(&mut self) {
        self.sums.iter_mut().for_each(|v| *v = 0.0);
        self.counts.iter_mut().for_each(|v| *v = 0.0);
    }

    /// `corr[(j·B + φ)·E + e] = c_e(φ)` and `energy[j·B + φ] = E(φ)` for every rate `j`.
    pub(super) fn correlate(&self, corr: &mut [f64], energy: &mut [f64]) {
        let b = self.bins;
        for j in 0..self.rates_hz.len() {
            let t = &self.templates[j * b..(j + 1) * b];
            let n = &self.counts[j * b..(j + 1) * b];
            let total_n: f64 = n.iter().sum();
            let mut total_f = [0.0; ELEMENTS];
            for k in 0..b {
                let s = &self.sums[(j * b + k) * ELEMENTS..(j * b + k + 1) * ELEMENTS];
                for e in 0..ELEMENTS {
                    total_f[e] += s[e];
                }
            }
            for phi in 0..b {
                let (mut tn, mut ttn) = (0.0, 0.0);
                let mut tf = [0.0; ELEMENTS];
                for k in 0..b {
                    let tv = t[(k + b - phi) % b];
                    tn += tv * n[k];
                    ttn += tv * tv * n[k];
                    let s = &self.sums[(j * b + k) * ELEMENTS..(j * b + k + 1) * ELEMENTS];
                    for e in 0..ELEMENTS {
                        tf[e] += tv * s[e];
                    }
                }
                let at = j * b + phi;
                if total_n <= 0.0 {
                    energy[at] = 0.0;
                    corr[at * ELEMENTS..(at + 1) * ELEMENTS].fill(0.0);
                    continue;
                }
                let mu = tn / total_n;
                energy[at] = (ttn - mu * tn).max(0.0);
                for e in 0..ELEMENTS {
                    corr[at * ELEMENTS + e] = tf[e] - mu * total_f[e];
                }
            }
        }
    }
}
