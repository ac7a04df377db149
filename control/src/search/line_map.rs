//! The search's belief about where the artery runs: a posterior over straight lines through
//! the region (offset and heading), and one more hypothesis, "no artery here".
//!
//! Over a search region (a few centimetres) the artery is close to straight: a 25 mm radius
//! bends a 20 mm chord by 2 mm, and the seed's arcs by under 0.5 mm. A line is
//! `z(x) = z_c + offset + tan(heading) (x − x_c)` about the region's centre `(x_c, z_c)`;
//! the prior is uniform over offsets that put the line through the region's middle column
//! and headings within the configured cone about the expected course (`+x` unless the
//! surgeon names another), never steeper than 80 degrees from `x` (the array lies along
//! `z` and can follow only an artery that crosses it). A grid, not a particle set or a Gaussian: the
//! posterior after one look is a band (every line through the felt point), after a miss a
//! hole, and a grid holds both exactly at a few tens of thousands of cells.
//!
//! A look at rest with the array centred at `(x_l, z_l)` reads where a line crosses the
//! element line `x = x_l`: `ξ = z(x_l) − z_l`. Its likelihood, with `p_d` the chance to feel
//! an artery within the array's reach `|ξ| ≤ R`, and `p_fa` the chance of a false detection:
//! - nothing felt: `1 − p_d` within the inner reach (`R` less two pitches: over the outer
//!   elements a pulse may be missed or felt only as a flank), 1 beyond it and for "no
//!   artery";
//! - a flank (a pulse the kernel cannot place): `1 − p_d` within the inner reach, 1
//!   beyond, `p_fa` for "no artery";
//! - felt at `ξ_m ± s`: `p_d · N(ξ_m − ξ; s² + floor²)` within reach, else `p_fa / 2R`.

use crate::frames::SurfacePoint;

use super::region::Region;

/// No line is steeper than this from `+x`, rad: the array lies along `z` and feels an
/// artery along it only as a flat pattern no kernel places.
pub const MAX_HEADING_RAD: f64 = 80.0 * std::f64::consts::PI / 180.0;

/// How far inside the array's reach a pulse that cannot be placed may still lie, m: two
/// pitches of the seed's array (an artery over the outer two elements is placed at the edge).
pub const FLANK_MARGIN_M: f64 = 4e-3;

/// What one look found, in the terms the map needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LookReading {
    /// No pulse in the window.
    Nothing,
    /// A pulse whose artery crosses the element line at `offset_z_m` from the sensor centre,
    /// with standard error `se_m`.
    Felt { offset_z_m: f64, se_m: f64 },
    /// A pulse that the kernel cannot place on the array (at or beyond its edge, or on a
    /// kernel's far lobe): the artery is not under the array's inner part, where it would
    /// have been placed, but it may be near.
    Flank,
}

/// The model's constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSettings {
    /// Largest heading of the artery from the expected course, rad.
    pub max_heading_rad: f64,
    /// The expected course's heading from `+x`, rad (0: along `x`).
    pub heading_centre_rad: f64,
    /// Grid steps.
    pub offset_step_m: f64,
    pub heading_step_rad: f64,
    /// Half the span along `z` over which a look feels an artery, m.
    pub reach_m: f64,
    /// Chance of feeling an artery within reach; of a false detection.
    pub p_detect: f64,
    pub p_false: f64,
    /// Added in quadrature to every felt place's SE: the belief's own error at rest and the
    /// line's departure from a bending course, m.
    pub place_floor_m: f64,
    /// Prior probability that the region holds no artery.
    pub prior_absent: f64,
}

/// The posterior.
#[derive(Debug, Clone)]
pub struct LineMap {
    settings: MapSettings,
    centre: SurfacePoint,
    offsets: Vec<f64>,
    tans: Vec<f64>,
    headings: Vec<f64>,
    /// Log posterior of each (heading, offset) cell, heading-major, unnormalized.
    log_p: Vec<f64>,
    log_absent: f64,
}

/// A summary of the posterior for reports and stopping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSummary {
    /// Probability that the region holds an artery.
    pub p_present: f64,
    /// The line's posterior mean heading and its SD, rad (given an artery).
    pub heading_rad: f64,
    pub heading_sd_rad: f64,
    /// The line's mean and SD of `z` at the region's centre `x`, m.
    pub offset_m: f64,
    pub offset_sd_m: f64,
}

impl LineMap {
    pub fn new(region: &Region, settings: MapSettings) -> Self {
        let centre = region.centre();
        let half = region.height_m() / 2.0;
        let n_off = (2.0 * half / settings.offset_step_m).round().max(1.0) as usize + 1;
        let offsets: Vec<f64> = (0..n_off)
            .map(|i| -half + 2.0 * half * i as f64 / (n_off - 1).max(1) as f64)
            .collect();
        // The cone about the expected course, within the array's reach (80 degrees of x).
        let limit = MAX_HEADING_RAD;
        let lo = (settings.heading_centre_rad - settings.max_heading_rad).max(-limit);
        let hi = (settings.heading_centre_rad + settings.max_heading_rad).min(limit);
        let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, hi) };
        let n_head = ((hi - lo) / settings.heading_step_rad).round().max(0.0) as usize + 1;
        let headings: Vec<f64> = (0..n_head)
            .map(|j| {
                if n_head == 1 {
                    0.5 * (lo + hi)
                } else {
                    lo + (hi - lo) * j as f64 / (n_head - 1) as f64
                }
            })
            .collect();
        let tans = headings.iter().map(|h| h.tan()).collect();
        let cells = offsets.len() * headings.len();
        let p_line = (1.0 - settings.prior_absent) / cells as f64;
        Self {
            settings,
            centre,
            log_p: vec![p_line.ln(); cells],
            log_absent: settings.prior_absent.ln(),
            offsets,
            tans,
            headings,
        }
    }

    pub fn settings(&self) -> &MapSettings {
        &self.settings
    }

    pub fn cells(&self) -> usize {
        self.log_p.len()
    }

    /// Where line `(j, i)` crosses `x`, m.
    fn z_at(&self, j: usize, i: usize, x: f64) -> f64 {
        self.centre.z_m + self.offsets[i] + self.tans[j] * (x - self.centre.x_m)
    }

    /// Weigh by `1 − p_d` every line crossing the inner part of a look centred at `at`.
    fn rule_out_inner(&mut self, at: SurfacePoint) {
        let inner = self.settings.reach_m - FLANK_MARGIN_M;
        let miss = (1.0 - self.settings.p_detect).ln();
        let n_off = self.offsets.len();
        for j in 0..self.headings.len() {
            for i in 0..n_off {
                if (self.z_at(j, i, at.x_m) - at.z_m).abs() <= inner {
                    self.log_p[j * n_off + i] += miss;
                }
            }
        }
    }

    /// Update with one look centred at `at`.
    pub fn observe(&mut self, at: SurfacePoint, reading: LookReading) {
        let s = self.settings;
        let reach = s.reach_m;
        let beyond_felt = (s.p_false / (2.0 * reach)).ln();
        let n_off = self.offsets.len();
        match reading {
            // A miss and a flank both rule out the lines under the array's inner part (over
            // the outer elements a pulse may be missed or felt only as a flank); they differ
            // in what they say about "no artery".
            LookReading::Nothing => {
                self.rule_out_inner(at);
                self.log_absent += (1.0 - s.p_false).ln();
            }
            LookReading::Flank => {
                self.rule_out_inner(at);
                self.log_absent += s.p_false.ln();
            }
            LookReading::Felt { offset_z_m, se_m } => {
                let var = se_m * se_m + s.place_floor_m * s.place_floor_m;
                let norm = -0.5 * (2.0 * std::f64::consts::PI * var).ln() + s.p_detect.ln();
                for j in 0..self.headings.len() {
                    for i in 0..n_off {
                        let xi = self.z_at(j, i, at.x_m) - at.z_m;
                        let l = if xi.abs() <= reach {
                            let d = offset_z_m - xi;
                            norm - 0.5 * d * d / var
                        } else {
                            beyond_felt
                        };
                        self.log_p[j * n_off + i] += l;
                    }
                }
                self.log_absent += beyond_felt;
            }
        }
    }

    /// The normalized posterior: the probability of each cell and of "no artery".
    pub fn probabilities(&self, out: &mut Vec<f64>) -> f64 {
        let max = self.log_p.iter().copied().fold(self.log_absent, f64::max);
        out.clear();
        out.extend(self.log_p.iter().map(|l| (l - max).exp()));
        let absent = (self.log_absent - max).exp();
        let total: f64 = out.iter().sum::<f64>() + absent;
        for p in out.iter_mut() {
            *p /= total;
        }
        absent / total
    }

    pub fn summary(&self) -> MapSummary {
        let mut p = Vec::with_capacity(self.log_p.len());
        let absent = self.probabilities(&mut p);
        let present = 1.0 - absent;
        let n_off = self.offsets.len();
        let (mut mh, mut mh2, mut mo, mut mo2) = (0.0, 0.0, 0.0, 0.0);
        for (k, pk) in p.iter().enumerate() {
            let (h, o) = (self.headings[k / n_off], self.offsets[k % n_off]);
            mh += pk * h;
            mh2 += pk * h * h;
            mo += pk * o;
            mo2 += pk * o * o;
        }
        let norm = present.max(f64::MIN_POSITIVE);
        let (mh, mo) = (mh / norm, mo / norm);
        MapSummary {
            p_present: present,
            heading_rad: mh,
            heading_sd_rad: (mh2 / norm - mh * mh).max(0.0).sqrt(),
            offset_m: self.centre.z_m + mo,
            offset_sd_m: (mo2 / norm - mo * mo).max(0.0).sqrt(),
        }
    }

    /// The probability that there is an artery and that its heading lies within `tol_rad`
    /// of `heading_rad`: a credible mass, which a few far-off lines (one felt point taken
    /// for a false alarm) cannot inflate as they inflate an SD.
    pub fn heading_mass_within(&self, heading_rad: f64, tol_rad: f64) -> f64 {
        let mut p = Vec::with_capacity(self.log_p.len());
        self.probabilities(&mut p);
        let n_off = self.offsets.len();
        p.chunks(n_off)
            .zip(&self.headings)
            .filter(|(_, h)| (*h - heading_rad).abs() <= tol_rad)
            .map(|(row, _)| row.iter().sum::<f64>())
            .sum()
    }

    /// The map as a picture: over a grid of `nx` by `nz` cells covering `region`, the
    /// probability that the artery crosses each cell's column within that cell (each
    /// column sums to the probability that the artery crosses the column inside the
    /// region). Row-major by `x` column, `z` within it.
    pub fn occupancy(&self, region: &Region, nx: usize, nz: usize) -> Vec<f64> {
        let mut out = vec![0.0; nx * nz];
        if nx == 0 || nz == 0 {
            return out;
        }
        let mut p = Vec::with_capacity(self.log_p.len());
        self.probabilities(&mut p);
        let (w, h) = (region.width_m() / nx as f64, region.height_m() / nz as f64);
        let n_off = self.offsets.len();
        for c in 0..nx {
            let x = region.x0_m + (c as f64 + 0.5) * w;
            for (j, &tan) in self.tans.iter().enumerate() {
                let base = self.centre.z_m + tan * (x - self.centre.x_m);
                for (i, pk) in p[j * n_off..(j + 1) * n_off].iter().enumerate() {
                    let k = ((base + self.offsets[i] - region.z0_m) / h).floor();
                    if k >= 0.0 && (k as usize) < nz {
                        out[c * nz + k as usize] += pk;
                    }
                }
            }
        }
        out
    }

    /// The SD of where the line crosses `x` (given an artery), m.
    pub fn crossing_sd_m(&self, x: f64) -> f64 {
        let mut p = Vec::with_capacity(self.log_p.len());
        let absent = self.probabilities(&mut p);
        let norm = (1.0 - absent).max(f64::MIN_POSITIVE);
        let n_off = self.offsets.len();
        let (mut m, mut m2) = (0.0, 0.0);
        for (k, pk) in p.iter().enumerate() {
            let z = self.z_at(k / n_off, k % n_off, x);
            m += pk * z;
            m2 += pk * z * z;
        }
        let m = m / norm;
        (m2 / norm - m * m).max(0.0).sqrt()
    }

    /// The most probable line: its heading and where it crosses the region's centre `x`.
    pub fn best_line(&self) -> (f64, f64) {
        let (k, _) = self
            .log_p
            .iter()
            .enumerate()
            .fold(
                (0, f64::NEG_INFINITY),
                |b, (k, &l)| if l > b.1 { (k, l) } else { b },
            );
        let n_off = self.offsets.len();
        (
            self.headings[k / n_off],
            self.centre.z_m + self.offsets[k % n_off],
        )
    }

    /// The expected information (nats) a look centred at `at` gives about the line and about
    /// whether there is one, given the posterior `p` (from [`Self::probabilities`]): the
    /// detection outcome's mutual information plus, weighted by the chance
    /// to feel it, what reading the crossing to `se_m` adds over its spread within reach.
    pub fn look_information(
        &self,
        p: &[f64],
        at: SurfacePoint,
        se_m: f64,
        bins: &mut [f64],
    ) -> f64 {
        let s = self.settings;
        let reach = s.reach_m;
        let n_off = self.offsets.len();
        bins.iter_mut().for_each(|b| *b = 0.0);
        let nb = bins.len();
        let inner = reach - FLANK_MARGIN_M;
        // `p_in`: within reach (felt and placed); `p_inner`: where a miss rules it out.
        let (mut p_in, mut p_inner) = (0.0, 0.0);
        for (j, &tan) in self.tans.iter().enumerate() {
            let base = self.centre.z_m + tan * (at.x_m - self.centre.x_m) - at.z_m;
            let row = &p[j * n_off..(j + 1) * n_off];
            for (i, pk) in row.iter().enumerate() {
                let xi = base + self.offsets[i];
                if xi.abs() <= reach {
                    p_in += pk;
                    if xi.abs() <= inner {
                        p_inner += pk;
                    }
                    let b = (((xi + reach) / (2.0 * reach)) * nb as f64) as usize;
                    bins[b.min(nb - 1)] += pk;
                }
            }
        }
        // The detection outcome as the miss model reads it: felt within the inner reach
        // with p_d, falsely with p_fa elsewhere.
        let p_felt = p_inner * s.p_detect + (1.0 - p_inner) * s.p_false;
        let detection = binary_entropy(p_felt)
            - p_inner * binary_entropy(s.p_detect)
            - (1.0 - p_inner) * binary_entropy(s.p_false);
        // The crossing's entropy within reach, against what one reading leaves.
        let mut place = 0.0;
        if p_in > 1e-12 {
            let width = 2.0 * reach / nb as f64;
            let h: f64 = bins
                .iter()
                .filter(|&&b| b > 0.0)
                .map(|&b| {
                    let q = b / p_in;
                    -q * (q / width).ln()
                })
                .sum();
            let sd = (se_m * se_m + s.place_floor_m * s.place_floor_m).sqrt();
            let left = 0.5 * (2.0 * std::f64::consts::PI * std::f64::consts::E * sd * sd).ln();
            place = p_in * s.p_detect * (h - left).max(0.0);
        }
        detection.max(0.0) + place
    }
}

fn binary_entropy(p: f64) -> f64 {
    let p = p.clamp(0.0, 1.0);
    let h = |q: f64| if q > 0.0 { -q * q.ln() } else { 0.0 };
    h(p) + h(1.0 - p)
}

#[cfg(test)]
#[path = "line_map_tests.rs"]
mod tests;
