//! The pulse's timing as a nuisance: a hidden track of (heart rate, phase) from segment to
//! segment, integrated out (the mixture likelihood ratio) and, for the report, followed
//! along its most probable path.
//!
//! Why not fold the whole window at one period: beat intervals vary by 5–10 % and their
//! deviations add up, so after 30 beats the beats stray by a quarter of a period or more
//! from any fixed-rate grid and a single fold smears the pulse away. Why not find each
//! beat: at a tenth of the noise one beat's SNR is about 1. So the pulse is taken to keep
//! its rate and phase within a segment (10 s by default; folded coherently there, see
//! `fold`), and between segments its phase diffuses by the beat-interval variability
//! (`cv √(beats)` of a cycle, Gaussian over phase bins) and its rate steps to a neighbouring
//! trial rate with probability `q` each way. The segments stay coherent with each other
//! along the track: a pulse adds `a √E` to every segment's score on its true track.
//!
//! For each artery position `x` and each of a few pulse amplitudes `β` (the amplitude is a
//! nuisance too) the forward algorithm computes the likelihood ratio of the data against
//! noise alone, averaged over all tracks under that prior; the statistic is the log of its
//! average over positions and amplitudes. Averaged, not maximized: under noise alone a
//! likelihood ratio averaged over a prior has mean 1 at every length, so the statistic's
//! law does not run away as the window grows (the sup over all lengths exceeds `ln(1/α)`
//! with probability at most `α`, Ville's inequality) and the threshold measured by Monte
//! Carlo sits just below that bound at every window length.
//!
//! A most probable track per position (max instead of sum, at the middle amplitude) carries
//! each element's summed correlation along it, for the position fit.

use crate::types::ELEMENTS;

/// Sums along one track.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PathSums {
    /// Σ of the projected, whitened correlations.
    pub score: f64,
    /// Σ of the template energies.
    pub energy: f64,
    /// Σ of each element's whitened correlation.
    pub elements: [f64; ELEMENTS],
}

#[derive(Clone)]
pub(super) struct TrackSettings {
    pub rates_hz: Vec<f64>,
    pub bins: usize,
    pub positions: usize,
    /// Amplitudes β (per unit template, whitened).
    pub amplitudes: Vec<f64>,
    pub segment_s: f64,
    pub beat_interval_cv: f64,
    pub rate_step_probability: f64,
}

#[derive(Clone)]
pub(super) struct Track {
    rates: Vec<f64>,
    bins: usize,
    positions: usize,
    amplitudes: Vec<f64>,
    /// Per rate: (phase offset in bins, probability).
    jitter: Vec<Vec<(isize, f64)>>,
    log_jitter: Vec<Vec<(isize, f64)>>,
    spread: Vec<f64>,
    spread_source: Vec<usize>,
    rate_steps: [(isize, f64); 3],
    lin: Vec<f64>,
    next: Vec<f64>,
    log_scale: Vec<f64>,
    map_obj: Vec<f64>,
    map_next: Vec<f64>,
    source: Vec<usize>,
    path: Vec<PathSums>,
    path_next: Vec<PathSums>,
    shifts: Vec<isize>,
    started: bool,
}

impl Track {
    pub(super) fn new(s: TrackSettings) -> Self {
        let b = s.bins;
        let jitter: Vec<Vec<(isize, f64)>> = s
            .rates_hz
            .iter()
            .map(|&f| {
                let sd = s.beat_interval_cv * (s.segment_s * f).sqrt() * b as f64;
                let reach = ((3.0 * sd).ceil() as isize).clamp(0, (b as isize - 1) / 2);
                let w: Vec<(isize, f64)> = (-reach..=reach)
                    .map(|d| {
                        let v = if sd > 0.0 {
                            (-0.5 * (d as f64 / sd).powi(2)).exp()
                        } else {
                            f64::from(u8::from(d == 0))
                        };
                        (d, v)
                    })
                    .collect();
                let total: f64 = w.iter().map(|(_, v)| v).sum();
                w.into_iter().map(|(d, v)| (d, v / total)).collect()
            })
            .collect();
        let q = s.rate_step_probability;
        let states = s.rates_hz.len() * b;
        let xk = s.positions * s.amplitudes.len();
        Self {
            rates: s.rates_hz,
            bins: b,
            positions: s.positions,
            amplitudes: s.amplitudes,
            log_jitter: jitter
                .iter()
                .map(|w: &Vec<(isize, f64)>| w.iter().map(|&(d, p)| (d, p.ln())).collect())
                .collect(),
            jitter,
            spread: vec![0.0; states],
            spread_source: vec![0; states],
            rate_steps: [(-1, q), (0, 1.0 - 2.0 * q), (1, q)],
            lin: vec![1.0 / states as f64; xk * states],
            next: vec![0.0; states],
            log_scale: vec![0.0; xk],
            map_obj: vec![0.0; s.positions * states],
            map_next: vec![0.0; states],
            source: vec![0; states],
            path: vec![PathSums::default(); s.positions * states],
            path_next: vec![PathSums::default(); states],
            shifts: Vec::new(),
            started: false,
        }
    }

    fn states(&self) -> usize {
        self.rates.len() * self.bins
    }

    /// One segment: `projected[x·S + s]`, `energy[s]`, `whitened[s·E + e]` (`s = j·B + φ`),
    /// the segment starting `boundary_s` after the stream's start.
    pub(super) fn update(
        &mut self,
        boundary_s: f64,
        projected: &[f64],
        energy: &[f64],
        whitened: &[f64],
    ) {
        let (b, nj, ns) = (self.bins, self.rates.len(), self.states());
        // Phase bin shift when the rate steps from j to j + d, keeping the pulse's phase.
        self.shifts.clear();
        for j in 0..nj {
            for &(d, _) in &self.rate_steps {
                let j2 = (j as isize + d).clamp(0, nj as isize - 1) as usize;
                let shift = ((self.rates[j2] - self.rates[j]) * boundary_s * b as f64).round();
                self.shifts.push(shift.rem_euclid(b as f64) as isize);
            }
        }
        let middle = self.amplitudes[self.amplitudes.len() / 2];
        for x in 0..self.positions {
            let p = &projected[x * ns..(x + 1) * ns];
            for k in 0..self.amplitudes.len() {
                let beta = self.amplitudes[k];
                let at = (x * self.amplitudes.len() + k) * ns;
                if self.started {
                    self.predict(at);
                } else {
                    self.next.copy_from_slice(&self.lin[at..at + ns]);
                }
                let gain = |s: usize| beta * p[s] - 0.5 * beta * beta * energy[s];
                let top = (0..ns).map(gain).fold(f64::NEG_INFINITY, f64::max);
                let mut peak = 0.0f64;
                for s in 0..ns {
                    self.next[s] *= (gain(s) - top).exp();
                    peak = peak.max(self.next[s]);
                }
                let xk = x * self.amplitudes.len() + k;
                if peak > 0.0 && peak.is_finite() {
                    self.log_scale[xk] += top + peak.ln();
                    for s in 0..ns {
                        self.lin[at + s] = self.next[s] / peak;
                    }
                } else {
                    self.log_scale[xk] = f64::NEG_INFINITY;
                }
            }
            // The most probable track at the middle amplitude.
            let at = x * ns;
            if self.started {
                self.map_predict(at);
            } else {
                self.map_next.fill(0.0);
                for (s, src) in self.source.iter_mut().enumerate() {
                    *src = s;
                }
            }
            for to in 0..ns {
                let prev = if self.started {
                    self.path[at + self.source[to]]
                } else {
                    PathSums::default()
                };
                let mut now = prev;
                now.score += p[to];
                now.energy += energy[to];
                for e in 0..ELEMENTS {
                    now.elements[e] += whitened[to * ELEMENTS + e];
                }
                self.path_next[to] = now;
                self.map_next[to] += middle * p[to] - 0.5 * middle * middle * energy[to];
            }
            self.path[at..at + ns].copy_from_slice(&self.path_next);
            self.map_obj[at..at + ns].copy_from_slice(&self.map_next);
        }
        self.started = true;
    }

    /// Spread one (position, amplitude)'s state over the next segment's by the prior:
    /// the phase jitter (a short circular convolution within each rate), then the rate
    /// step with its phase shift.
    fn predict(&mut self, at: usize) {
        let (b, nj, ns) = (self.bins, self.rates.len(), self.states());
        for j in 0..nj {
            let row = &self.lin[at + j * b..at + (j + 1) * b];
            let out = &mut self.spread[j * b..(j + 1) * b];
            out.fill(0.0);
            for &(d, w) in &self.jitter[j] {
                for (phi, &m) in row.iter().enumerate() {
                    out[(phi as isize + d).rem_euclid(b as isize) as usize] += m * w;
                }
            }
        }
        self.next[..ns].fill(0.0);
        for j in 0..nj {
            for (r, &(d, pj)) in self.rate_steps.iter().enumerate() {
                let j2 = (j as isize + d).clamp(0, nj as isize - 1) as usize;
                let shift = self.shifts[j * 3 + r] as usize;
                for phi in 0..b {
                    self.next[j2 * b + (phi + shift) % b] += pj * self.spread[j * b + phi];
                }
            }
        }
    }

    /// The most probable predecessor of every state (max instead of sum), into
    /// `map_next` (the best log prior path value) and `source`.
    fn map_predict(&mut self, at: usize) {
        let (b, nj) = (self.bins, self.rates.len());
        for j in 0..nj {
            for phi2 in 0..b {
                let mut best = (f64::NEG_INFINITY, 0usize);
                for &(d, lw) in &self.log_jitter[j] {
                    let phi = (phi2 as isize - d).rem_euclid(b as isize) as usize;
                    let v = self.map_obj[at + j * b + phi] + lw;
                    if v > best.0 {
                        best = (v, j * b + phi);
                    }
                }
                self.spread[j * b + phi2] = best.0;
                self.spread_source[j * b + phi2] = best.1;
            }
        }
        self.map_next.fill(f64::NEG_INFINITY);
        for j in 0..nj {
            for (r, &(d, pj)) in self.rate_steps.iter().enumerate() {
                if pj <= 0.0 {
                    continue;
                }
                let lp = pj.ln();
                let j2 = (j as isize + d).clamp(0, nj as isize - 1) as usize;
                let shift = self.shifts[j * 3 + r] as usize;
                for phi in 0..b {
                    let to = j2 * b + (phi + shift) % b;
                    let v = self.spread[j * b + phi] + lp;
                    if v > self.map_next[to] {
                        self.map_next[to] = v;
                        self.source[to] = self.spread_source[j * b + phi];
                    }
                }
            }
        }
    }

    /// Log of the likelihood ratio averaged over positions, amplitudes and tracks.
    pub(super) fn log_ratio(&self) -> f64 {
        let terms = self.per_position_amplitude();
        log_mean_exp(&terms)
    }

    fn per_position_amplitude(&self) -> Vec<f64> {
        let ns = self.states();
        (0..self.positions * self.amplitudes.len())
            .map(|xk| {
                let total: f64 = self.lin[xk * ns..(xk + 1) * ns].iter().sum();
                self.log_scale[xk] + total.ln()
            })
            .collect()
    }

    /// Log ratio of each position (averaged over amplitudes and tracks).
    pub(super) fn position_log_ratios(&self) -> Vec<f64> {
        let terms = self.per_position_amplitude();
        terms
            .chunks(self.amplitudes.len())
            .map(log_mean_exp)
            .collect()
    }

    /// The rate's posterior mean (Hz) at position `x`, all amplitudes pooled.
    pub(super) fn rate_hz(&self, x: usize) -> f64 {
        let (b, ns, na) = (self.bins, self.states(), self.amplitudes.len());
        let terms = self.per_position_amplitude();
        let top = terms[x * na..(x + 1) * na]
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        let (mut w, mut wf) = (0.0, 0.0);
        for k in 0..na {
            let at = (x * na + k) * ns;
            let scale = (self.log_scale[x * na + k] - top).exp();
            for (j, f) in self.rates.iter().enumerate() {
                let m: f64 = self.lin[at + j * b..at + (j + 1) * b].iter().sum::<f64>() * scale;
                w += m;
                wf += m * f;
            }
        }
        if w > 0.0 { wf / w } else { f64::NAN }
    }

    /// The most probable track's sums at position `x`, and its current rate (Hz).
    pub(super) fn best_path(&self, x: usize) -> (PathSums, f64) {
        let ns = self.states();
        let obj = &self.map_obj[x * ns..(x + 1) * ns];
        let (best, _) =
            obj.iter().enumerate().fold(
                (0, f64::NEG_INFINITY),
                |a, (s, &v)| if v > a.1 { (s, v) } else { a },
            );
        (self.path[x * ns + best], self.rates[best / self.bins])
    }
}

fn log_mean_exp(v: &[f64]) -> f64 {
    let top = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return top;
    }
    top + (v.iter().map(|t| (t - top).exp()).sum::<f64>() / v.len() as f64).ln()
}
