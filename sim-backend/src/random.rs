//! Seeded random numbers for the simulation: uniform and normal draws from ChaCha streams.
//!
//! Every random effect (sensor noise, beat-to-beat variability, frame drops) draws from its
//! own stream derived from the trial's seed, so adding draws to one effect never changes
//! another, and the same seed gives bit-identical output.

use rand::Rng;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// A uniform draw in (0, 1): never exactly 0, so logarithms are safe.
pub fn uniform_open(rng: &mut impl Rng) -> f64 {
    // 53 random mantissa bits, offset by half a step.
    ((rng.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// A standard normal draw (Box–Muller; one of the pair is discarded for simplicity and
/// stream stability).
pub fn standard_normal(rng: &mut impl Rng) -> f64 {
    let u1 = uniform_open(rng);
    let u2 = uniform_open(rng);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Independent named streams from one trial seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    SensorNoise = 1,
    Pulse = 2,
    Faults = 3,
}

/// The generator for one stream of one trial.
pub fn stream(seed: u64, which: Stream) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(which as u64);
    rng
}

/// The seed for stream-specific sub-generators that take a plain `u64` seed.
pub fn stream_seed(seed: u64, which: Stream) -> u64 {
    stream(seed, which).next_u64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_draws_have_unit_variance_and_streams_differ() {
        let mut rng = stream(7, Stream::SensorNoise);
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
        let a = stream(7, Stream::SensorNoise).next_u64();
        let b = stream(7, Stream::Pulse).next_u64();
        assert_ne!(a, b);
        assert_eq!(a, stream(7, Stream::SensorNoise).next_u64());
    }
}
