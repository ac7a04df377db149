//! The elements' noise SD measured from the data: the median absolute difference of
//! consecutive samples.
//!
//! Detection thresholds are multiples of the noise SD. The configured value (the seed's
//! 0.012 N) may be wrong for a given sensor or day; a threshold on a wrong σ either misses
//! pulses or reports noise as arteries. Consecutive differences of white noise have SD
//! `σ √2`; the pulse and slow drift change little between samples at 100 Hz, and the
//! median ignores the few large steps (a square wave's edges), so
//! `σ ≈ median |Δx| / (0.6745 √2)` pooled over all elements. The scratch buffer is allocated
//! once.

use crate::types::{ELEMENTS, TactileFrame};

/// `1 / (Φ⁻¹(3/4) √2)`: median |Δx| to σ for Gaussian noise.
const MAD_DIFF_TO_SD: f64 = 1.0 / (0.674_489_750_196_081_7 * std::f64::consts::SQRT_2);

/// Fewest differences an estimate is made from.
const MIN_DIFFERENCES: usize = 20;

#[derive(Debug, Clone)]
pub struct NoiseLevel {
    scratch: Vec<f64>,
}

impl NoiseLevel {
    /// An estimator for windows of up to `max_frames` frames.
    pub fn new(max_frames: usize) -> Self {
        Self {
            scratch: Vec::with_capacity(max_frames.max(2) * ELEMENTS),
        }
    }

    /// The noise SD of the frames (in time order; non-finite frames and pairs across a
    /// sequence gap are skipped), N. `None` with too few differences. Uses at most
    /// `max_frames` frames.
    pub fn estimate<'a>(&mut self, frames: impl Iterator<Item = &'a TactileFrame>) -> Option<f64> {
        self.scratch.clear();
        let room = self.scratch.capacity() / ELEMENTS;
        let mut previous: Option<&TactileFrame> = None;
        for f in frames.filter(|f| f.is_finite()).take(room + 1) {
            if let Some(p) = previous
                && p.seq.checked_add(1) == Some(f.seq)
            {
                for e in 0..ELEMENTS {
                    self.scratch.push((f.force_n[e] - p.force_n[e]).abs());
                }
            }
            previous = Some(f);
        }
        let n = self.scratch.len();
        if n < MIN_DIFFERENCES {
            return None;
        }
        let (_, median, _) = self.scratch.select_nth_unstable_by(n / 2, f64::total_cmp);
        Some(*median * MAD_DIFF_TO_SD)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy(n: usize, sd: f64, signal: impl Fn(f64) -> f64) -> Vec<TactileFrame> {
        let mut state = 99u64;
        let mut u = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|i| {
                let t = i as f64 * 0.01;
                TactileFrame {
                    t_s: t,
                    seq: i as u64,
                    force_n: std::array::from_fn(|_| {
                        let (a, b) = (u().max(1e-300), u());
                        signal(t) + sd * (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
                    }),
                }
            })
            .collect()
    }

    #[test]
    fn measures_white_noise_under_a_square_pulse() {
        let mut est = NoiseLevel::new(1000);
        for sd in [0.006, 0.012, 0.024] {
            let f = noisy(
                400,
                sd,
                |t| if t.fract() < 0.5 { 0.06 } else { 0.0 } + 0.1 * t,
            );
            let got = est.estimate(f.iter()).expect("enough samples");
            assert!((got / sd - 1.0).abs() < 0.1, "{got} vs {sd}");
        }
    }

    #[test]
    fn flat_short_and_gapped_inputs() {
        let mut est = NoiseLevel::new(100);
        let flat = noisy(50, 0.0, |_| 0.3);
        assert_eq!(est.estimate(flat.iter()), Some(0.0));
        assert_eq!(est.estimate(flat[..2].iter()), None);
        assert_eq!(est.estimate([].iter()), None);
        // Every other frame missing: no consecutive pairs.
        let gapped: Vec<_> = noisy(60, 0.01, |_| 0.0).into_iter().step_by(2).collect();
        assert_eq!(est.estimate(gapped.iter()), None);
        // More frames than the capacity: uses the first ones, does not grow.
        let long = noisy(500, 0.01, |_| 0.0);
        assert!(est.estimate(long.iter()).is_some());
        assert!(est.scratch.capacity() <= 100 * ELEMENTS + ELEMENTS);
    }
}
