//! Synthetic tactile signals for tests and measurements (dev-only, never in the library).
//!
//! - [`Rng`]: a small deterministic generator (SplitMix64) with normal deviates.
//! - [`Waveform`]: the pressure pulse, normalised to 0..1: the seed's solenoid square wave
//!   (a tube inflated and vented at about 1 s intervals, with a first-order rise and fall),
//!   or a physiological arterial pulse (fast systolic upstroke, dicrotic notch, diastolic
//!   decay) at 1.0-1.67 Hz with beat-to-beat period jitter.
//! - [`element_gain`]: the surface pressure over a tube, DESIGN.md section 5,
//!   `p(x) = 2 Δp a² (h² − x²)/(x² + h²)²`, integrated over a 2 mm element and normalised
//!   to 1 for an element centred over the tube. It turns negative beyond |x| = h: far
//!   elements move out of phase.
//! - [`acquisition`]: one window of frames for an artery at a known (fractional) element.

use control::types::{ELEMENTS, TactileFrame};

/// SplitMix64: small, fast, deterministic; plenty for test noise.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    spare: Option<f64>,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self {
            state: seed ^ 0x9E37_79B9_7F4A_7C15,
            spare: None,
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let a = 2.0 * std::f64::consts::PI * u2;
        self.spare = Some(r * a.sin());
        r * a.cos()
    }
}

/// The shape of the pressure pulse in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Waveform {
    /// Inflate for half a period, vent for half; first-order rise and fall with `tau_s`.
    Square { rate_hz: f64, tau_s: f64 },
    /// Arterial pulse: systolic peak and dicrotic wave; each beat's period varies by
    /// `jitter` (relative SD).
    Physiological { rate_hz: f64, jitter: f64 },
    /// A pure sinusoid between 0 and 1.
    Sine { rate_hz: f64 },
}

impl Waveform {
    pub fn rate_hz(&self) -> f64 {
        match *self {
            Waveform::Square { rate_hz, .. }
            | Waveform::Physiological { rate_hz, .. }
            | Waveform::Sine { rate_hz } => rate_hz,
        }
    }

    /// `n` samples at `fs` Hz, starting at phase `phase` (0..1) of a cycle, values 0..1.
    pub fn samples(&self, n: usize, fs: f64, phase: f64, rng: &mut Rng) -> Vec<f64> {
        let dt = 1.0 / fs;
        match *self {
            Waveform::Sine { rate_hz } => (0..n)
                .map(|j| {
                    let t = j as f64 * dt + phase / rate_hz;
                    0.5 - 0.5 * (2.0 * std::f64::consts::PI * rate_hz * t).cos()
                })
                .collect(),
            Waveform::Square { rate_hz, tau_s } => {
                // Simulate the first-order tube through a few cycles of burn-in.
                let burn = (3.0 * fs / rate_hz).ceil() as usize;
                let alpha = 1.0 - (-dt / tau_s).exp();
                let mut y = 0.0;
                let mut out = Vec::with_capacity(n);
                for j in 0..burn + n {
                    let t = (j as f64 - burn as f64) * dt + phase / rate_hz;
                    let cycle = (t * rate_hz).rem_euclid(1.0);
                    let drive = if cycle < 0.5 { 1.0 } else { 0.0 };
                    y += alpha * (drive - y);
                    if j >= burn {
                        out.push(y);
                    }
                }
                out
            }
            Waveform::Physiological { rate_hz, jitter } => {
                let peak = beat_shape_max();
                let mut out = Vec::with_capacity(n);
                let mut period = 1.0 / rate_hz;
                let mut onset = -phase * period;
                for j in 0..n {
                    let t = j as f64 * dt;
                    while t >= onset + period {
                        onset += period;
                        period = (1.0 + jitter * rng.normal()).max(0.5) / rate_hz;
                    }
                    out.push(beat_shape((t - onset) / period) / peak);
                }
                out
            }
        }
    }
}

/// One beat of arterial pressure above diastolic, `phi` in 0..1: a systolic upstroke over
/// the first 12 % of the beat, a diastolic decay back to 0 at the end of the beat, and a
/// dicrotic notch and wave around 36-42 %.
fn beat_shape(phi: f64) -> f64 {
    const RISE: f64 = 0.12;
    const TAU: f64 = 0.3;
    let g = |c: f64, w: f64| (-((phi - c) / w).powi(2)).exp();
    let base = if phi < RISE {
        0.5 - 0.5 * (std::f64::consts::PI * phi / RISE).cos()
    } else {
        let end = (-(1.0 - RISE) / TAU).exp();
        ((-(phi - RISE) / TAU).exp() - end) / (1.0 - end)
    };
    base + 0.12 * g(0.42, 0.04) - 0.08 * g(0.36, 0.025)
}

fn beat_shape_max() -> f64 {
    (0..1000)
        .map(|k| beat_shape(k as f64 / 1000.0))
        .fold(0.0, f64::max)
}

/// Force on a 2 mm element whose centre is `x_m` from the tube axis, tube centre `depth_m`
/// deep, normalised so that an element centred over the tube gives 1.
pub fn element_gain(x_m: f64, depth_m: f64, element_m: f64) -> f64 {
    // The antiderivative of (h² − x²)/(x² + h²)² is x / (x² + h²).
    let f = |x: f64| x / (x * x + depth_m * depth_m);
    let over = |c: f64| f(c + element_m / 2.0) - f(c - element_m / 2.0);
    over(x_m) / over(0.0)
}

/// What one synthetic acquisition contains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AcquisitionSpec {
    pub samples: usize,
    pub sample_rate_hz: f64,
    /// The artery's position on the array, element index; `None` for noise only.
    pub artery_element: Option<f64>,
    /// Pulse swing of an element centred over the artery, N.
    pub swing_n: f64,
    pub waveform: Waveform,
    /// Tube centre depth, m (5 mm: the seed's model tube).
    pub depth_m: f64,
    pub pitch_m: f64,
    /// Noise SD per element and sample, N (the seed: 0.012 N).
    pub noise_sd_n: f64,
    /// Static contact force per element, N, plus a drift over the window (creep after a
    /// move), N: the total change from first to last sample, decaying exponentially.
    pub contact_n: f64,
    pub drift_n: f64,
}

impl AcquisitionSpec {
    pub fn seed_bench(samples: usize, waveform: Waveform, swing_n: f64) -> Self {
        Self {
            samples,
            sample_rate_hz: 100.0,
            artery_element: Some(4.5),
            swing_n,
            waveform,
            depth_m: 0.005,
            pitch_m: 0.002,
            noise_sd_n: 0.012,
            contact_n: 0.3,
            drift_n: 0.0,
        }
    }
}

/// Frames of one acquisition: sequence numbers from `first_seq`, times from `t0_s`.
pub fn acquisition(
    spec: &AcquisitionSpec,
    phase: f64,
    t0_s: f64,
    first_seq: u64,
    rng: &mut Rng,
) -> Vec<TactileFrame> {
    let wave = spec
        .waveform
        .samples(spec.samples, spec.sample_rate_hz, phase, rng);
    let gains: [f64; ELEMENTS] = std::array::from_fn(|e| match spec.artery_element {
        Some(a) => element_gain((e as f64 - a) * spec.pitch_m, spec.depth_m, spec.pitch_m),
        None => 0.0,
    });
    let offsets: [f64; ELEMENTS] =
        std::array::from_fn(|_| spec.contact_n * (1.0 + 0.2 * rng.normal()));
    let dt = 1.0 / spec.sample_rate_hz;
    let duration = spec.samples as f64 * dt;
    (0..spec.samples)
        .map(|j| {
            let t = j as f64 * dt;
            let creep =
                spec.drift_n * (1.0 - (-3.0 * t / duration).exp()) / (1.0 - (-3.0f64).exp());
            TactileFrame {
                t_s: t0_s + t,
                seq: first_seq + j as u64,
                force_n: std::array::from_fn(|e| {
                    offsets[e]
                        + creep
                        + spec.swing_n * gains[e] * wave[j]
                        + spec.noise_sd_n * rng.normal()
                }),
            }
        })
        .collect()
}
