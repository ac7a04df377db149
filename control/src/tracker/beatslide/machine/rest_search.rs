//! The search at rest: the pulse's rate, waveform and spatial pattern from a window with the
//! sensor still, and the kernel fit that places it.
//!
//! Under breathing the tissue carries the artery across the still array, which modulates
//! each element's pulse: the heart's line at `f_h` gets sidebands at `f_h ± f_b`, and the
//! artery's mean load sweeping the elements adds the breathing's own harmonics. Over a 4 s
//! window these can pass for a pulse at another rate (a fundamental near `f_h − f_b` with
//! its second harmonic on `f_h + f_b`), as strong as the heart's own, and the largest
//! statistic picked it: on the breathing family's reporting seeds three trials learned a
//! period of 1.5 s for a 1.0 s heart, and their seed points were 6-7 mm off. The two differ
//! in space: the heart's line has the artery's kernel as its pattern, a sideband the
//! kernel's derivative (two lobes of opposite sign), which no one kernel fits. So a pulse
//! whose pattern fails the one-kernel test ([`BeatSlide::fits_one_artery`]) is searched
//! again outside its own band; a pulse found there (not on the band's edge, which is the
//! refused line's flank) that one kernel fits is taken instead, or, when none does, the one
//! closest to a kernel for its strength. A pulse whose pattern passes is never searched again:
//! on still tissue nothing changes.

use super::*;
use crate::signal::placed_pulse::PlaceMiss;
use crate::signal::pulse_search;

/// Half the width of the band left out around a refused pulse's rate, in units of the
/// search's resolution: the statistic's peak is about two of them wide at its base.
const REFUSED_BAND_CYCLES: f64 = 1.0;
/// How much better, in chi-square, a mark's pulse must fit the kernel than its inverse: a
/// likelihood ratio of 100 (2 ln 100). On the scene families' tuning and reporting seeds
/// and 150 fresh seed-bench-mixed draws (2377 marks) it held back 7 of the 8 marks more
/// than 2 mm off (5-8 mm, margins 0.9-5.2) and 30 of the others.
pub(super) const SIGN_MARGIN_CHI2: f64 = 9.21;

/// How strong, against the refused pulse's statistic, a pulse elsewhere must be to replace
/// it: the heart's line was 0.9-1.0 of its sidebands' in the failures traced (breathing's
/// reporting seeds), while noise elsewhere, which any kernel fits, is far weaker.
const RIVAL_STRENGTH: f64 = 0.5;

impl BeatSlide {
    pub(super) fn search_settings(&self) -> PulseSearchSettings {
        let (lo, hi) = match self.pulse {
            Some(p) => {
                let period = p.clock.period_s();
                (
                    (period * (1.0 - KNOWN_PERIOD_RANGE)).max(self.params.min_period_s),
                    (period * (1.0 + KNOWN_PERIOD_RANGE)).min(self.params.max_period_s),
                )
            }
            None => (self.params.min_period_s, self.params.max_period_s),
        };
        PulseSearchSettings {
            min_period_s: lo,
            max_period_s: hi,
            threshold: self.params.detection_threshold,
            decimation: SEARCH_DECIMATION,
            min_cycles: MIN_CYCLES,
            coherent_s: self.params.coherent_s,
            plausible_min_period_s: self.params.min_period_s,
            plausible_max_period_s: self.params.max_period_s,
        }
    }

    /// Search the frames since `since_s` at rest; on success, the kernel fit too.
    pub(super) fn search_at_rest(
        &mut self,
        since_s: f64,
    ) -> Result<(PulseFound, KernelFit, SurfacePoint), Miss> {
        let settings = self.search_settings();
        let window = self.history.since(since_s);
        let sensor = window.mean_sensor().ok_or(Miss::NoPosition)?;
        let sigma = self
            .noise
            .estimate(window.frames())
            .unwrap_or(self.geometry.noise_sd_n)
            .max(self.geometry.noise_sd_n);
        let span_s = match (window.frames().next(), window.frames().last()) {
            (Some(a), Some(b)) => b.t_s - a.t_s,
            _ => 0.0,
        };
        let first = placed_pulse(&mut self.search, &window, sigma, &settings, &self.geometry)?;
        if self.fits_one_artery(&first.1) || span_s <= 0.0 {
            return Ok((first.0, first.1, sensor));
        }
        // Not one artery's pattern: look outside its band for one that fits better.
        let f = 1.0 / first.0.phase.period_s;
        let resolution = pulse_search::resolution_hz(span_s, &settings);
        let band = REFUSED_BAND_CYCLES * resolution;
        let grid = pulse_search::GRID_CYCLES * resolution;
        // Slower than the band (none when the band reaches zero), and faster.
        let below = (f > band).then(|| PulseSearchSettings {
            min_period_s: settings.min_period_s.max(1.0 / (f - band)),
            ..settings
        });
        let above = Some(PulseSearchSettings {
            max_period_s: settings.max_period_s.min(1.0 / (f + band)),
            ..settings
        });
        let first_statistic = first.0.statistic;
        let mut best = first;
        for range in [below, above].into_iter().flatten() {
            if range.min_period_s >= range.max_period_s {
                continue;
            }
            let Ok(other) = placed_pulse(&mut self.search, &window, sigma, &range, &self.geometry)
            else {
                continue;
            };
            // A peak at the band's edge is the refused line's own flank.
            if (1.0 / other.0.phase.period_s - f).abs() < band + grid {
                continue;
            }
            // The heart's line is about as strong as the sidebands it made: a weak peak
            // elsewhere (noise, which any kernel fits) is not it.
            if other.0.statistic < RIVAL_STRENGTH * first_statistic {
                continue;
            }
            if self.better_pulse(&other, &best) {
                best = other;
            }
        }
        let (found, fit) = best;
        Ok((found, fit, sensor))
    }

    /// How much better `found`'s pattern fits the kernel than its inverse's, in chi-square
    /// (infinite when the inverse cannot be fitted; zero when neither can). A strong pulse
    /// fits one sign by tens to thousands; at a weak pulse's noise a broad positive pattern
    /// and one negative element can fit about equally, the first as a kernel beyond the
    /// array's end, the second as a faint peak on it.
    pub(super) fn sign_margin_chi2(&self, found: &PulseFound) -> f64 {
        let se = found.amplitudes.se_per_sigma * found.noise_sd_n;
        let chi2 = |f: &PulseFound| {
            fit_kernel(&f.amplitudes.amplitude_n, se, &self.geometry).map(|k| k.chi2)
        };
        match (chi2(found), chi2(&found.flipped())) {
            (Ok(a), Ok(b)) => (a - b).abs(),
            (Ok(_), Err(_)) | (Err(_), Ok(_)) => f64::INFINITY,
            (Err(_), Err(_)) => 0.0,
        }
    }

    /// Is `a` a better reading of the window than `b`: one artery's pattern against none,
    /// the stronger of two that are, the closer to one kernel (its misfit per unit of
    /// signal) of two that are not.
    fn better_pulse(&self, a: &(PulseFound, KernelFit), b: &(PulseFound, KernelFit)) -> bool {
        // The kernel's chi-square per unit of the pattern's own energy (its squared SNR
        // over the trusted elements).
        let weights = self.geometry.skip_elements.weights();
        let misfit = |(found, fit): &(PulseFound, KernelFit)| {
            let se = found.amplitudes.se_per_sigma * found.noise_sd_n;
            let energy: f64 = (found.amplitudes.amplitude_n.iter().zip(&weights))
                .map(|(a, w)| w * (a / se).powi(2))
                .sum();
            fit.chi2 / energy.max(f64::MIN_POSITIVE)
        };
        match (self.fits_one_artery(&a.1), self.fits_one_artery(&b.1)) {
            (true, false) => true,
            (false, true) => false,
            (true, true) => a.0.statistic > b.0.statistic,
            (false, false) => misfit(a) < misfit(b),
        }
    }
}

/// The strongest pulse in `settings`' range among the window's frames, placed
/// ([`crate::signal::placed_pulse`]).
fn placed_pulse(
    search: &mut PulseSearch,
    window: &super::super::history::Window<'_>,
    sigma: f64,
    settings: &PulseSearchSettings,
    geometry: &ArrayGeometry,
) -> Result<(PulseFound, KernelFit), Miss> {
    crate::signal::placed_pulse::placed_pulse(search, window.frames(), sigma, settings, geometry)
        .map(|p| (p.found, p.fit))
        .map_err(|e| match e {
            PlaceMiss::Search(m) => Miss::Search(m),
            PlaceMiss::Kernel(k) => Miss::Kernel(k),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::harmonic::{Projection, PulsePhase};
    use crate::signal::kernel_fit::element_kernel;
    use crate::types::ELEMENTS;

    fn found(amplitude_n: [f64; ELEMENTS], se_n: f64) -> PulseFound {
        let noise_sd_n = 0.0138;
        let mut waveform = Waveform::zeros();
        waveform[0] = 1.0;
        PulseFound {
            phase: PulsePhase {
                t_ref_s: 0.0,
                period_s: 0.76,
            },
            waveform,
            amplitudes: Projection {
                amplitude_n,
                se_per_sigma: se_n / noise_sd_n,
            },
            statistic: 9.0,
            noise_sd_n,
        }
    }

    fn tracker() -> BeatSlide {
        BeatSlide::new(BeatSlideParams::default(), ArrayGeometry::default()).expect("defaults")
    }

    fn negated(a: [f64; ELEMENTS]) -> [f64; ELEMENTS] {
        a.map(|v| -v)
    }

    #[test]
    fn a_clear_pulse_fits_one_sign_by_far_either_way_round() {
        let g = ArrayGeometry::default();
        // 30 mN at element 4.3, 5 mm wide, each amplitude known to 1 mN.
        let a: [f64; ELEMENTS] = std::array::from_fn(|e| {
            0.03 * element_kernel((e as f64 - 4.3) * g.pitch_m, 0.005, g.pitch_m)
                / element_kernel(0.0, 0.005, g.pitch_m)
        });
        let t = tracker();
        let margin = t.sign_margin_chi2(&found(a, 0.001));
        assert!(margin > 100.0, "margin {margin}");
        let inverse = t.sign_margin_chi2(&found(negated(a), 0.001));
        assert!(
            (margin - inverse).abs() < 1e-6 * margin,
            "{margin} vs {inverse}"
        );
    }

    #[test]
    fn a_pulse_at_the_noise_does_not_know_its_sign() {
        // The first mark of seed-bench-mixed draw 5147 (31 kPa on the seed's tube 5.2 mm
        // deep, 13.8 mN of element noise), as the simulator's frames gave it: the artery
        // lay under element 3, where the pattern is broad and positive; the search took the
        // inverse, whose one peak at element 8 fits the kernel slightly better (chi-square
        // 8.5 against 9.7), and the seed point was 6.3 mm off.
        let a = [
            -0.002417, -0.002476, -0.003169, -0.005566, -0.002667, -0.002372, -0.002080, 0.000427,
            0.004185, 0.000073,
        ];
        let se = 9.668e-4;
        let t = tracker();
        let margin = t.sign_margin_chi2(&found(a, se));
        assert!(margin < SIGN_MARGIN_CHI2, "margin {margin}");
        assert!((margin - 1.2).abs() < 0.1, "margin {margin}");
        // The two readings are far apart: which one holds matters.
        let g = ArrayGeometry::default();
        let place = |a| fit_kernel(&a, se, &g).expect("fit").element;
        assert!((place(a) - place(negated(a))).abs() > 2.0);
    }
}
