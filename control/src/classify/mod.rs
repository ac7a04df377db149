//! What is under the sensor: tissue, a lump that does not pulse, an artery, or an artery
//! with a suspected stenosis, with a confidence.
//!
//! The logic is Table 2 of the FEM papers (seeds/001, 002) applied to a window of tactile
//! frames: a uniform, constant image is tissue; a constant peak is a lump (tumour); a peak
//! that changes with time is an artery; and of two arteries under the same loading, the one
//! with the larger peak and the smaller swing is the stenotic one.
//!
//! "Changes with time" is judged on the coherent part of the window: the largest eigenvalue
//! of the 10 x 10 covariance of the detrended frames against the largest eigenvalue that
//! white noise alone would give (the Marchenko–Pastur edge σ²(1 + √(p/n))²). A pulse is seen
//! by every element at once (with a sign that flips beyond the artery's depth), noise is
//! not, so this detects pulses well below the per-element noise that a max - min test would
//! drown in. Everything is fixed-size arrays: [`Window::push`] and [`Window::classify`] never
//! allocate.

#![allow(clippy::needless_range_loop)] // index loops read like the formulas

use serde::{Deserialize, Serialize};

use crate::types::{ELEMENTS, TactileFrame};

/// What the window shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Kind {
    Tissue,
    Lump,
    Artery,
    ArteryStenosisSuspected,
}

/// Thresholds (every one configurable; defaults suit the seed's sensor).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClassifyParams {
    /// Per-element noise SD, N (a floor: the window's own noise estimate is used if larger).
    pub noise_sd_n: f64,
    /// Static contrast (max - min of the element means) that still counts as uniform, N.
    pub uniform_tolerance_n: f64,
    /// ...and as a fraction of the mean force.
    pub uniform_tolerance_rel: f64,
    /// Coherent-variance ratio to the noise edge above which the image is time-varying.
    pub pulse_ratio: f64,
    /// Relative margin for "larger peak" and "smaller swing" against a reference artery.
    pub stenosis_margin: f64,
    /// Frames averaged into one sample before the covariance (a box low-pass: at 100 Hz, 8
    /// frames keep 98% of a 1.2 Hz pulse and cut white noise variance 8-fold).
    pub bin_frames: usize,
    /// Fewest frames a window needs.
    pub min_frames: usize,
}

impl Default for ClassifyParams {
    fn default() -> Self {
        Self {
            noise_sd_n: 0.012,
            uniform_tolerance_n: 0.01,
            uniform_tolerance_rel: 0.05,
            pulse_ratio: 1.3,
            stenosis_margin: 0.03,
            bin_frames: 8,
            min_frames: 200,
        }
    }
}

impl ClassifyParams {
    pub fn is_valid(&self) -> bool {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let non_neg = |v: f64| v.is_finite() && v >= 0.0;
        pos(self.noise_sd_n)
            && non_neg(self.uniform_tolerance_n)
            && non_neg(self.uniform_tolerance_rel)
            && self.pulse_ratio.is_finite()
            && self.pulse_ratio > 1.0
            && non_neg(self.stenosis_margin)
            && self.bin_frames >= 1
            && self.min_frames >= 3 * self.bin_frames.max(1)
    }
}

/// What the window was reduced to.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Features {
    pub frames: usize,
    /// Mean force per element over the window, N.
    pub mean_n: [f64; ELEMENTS],
    /// Largest element mean and where it is.
    pub peak_n: f64,
    pub peak_element: usize,
    /// Max - min of the element means, N.
    pub static_contrast_n: f64,
    /// Sine-equivalent peak-to-peak swing of the coherent (pulsatile) component at each
    /// element, signed by its phase relative to the strongest element, N.
    pub swing_n: [f64; ELEMENTS],
    /// Largest |swing| and its element.
    pub swing_peak_n: f64,
    pub swing_element: usize,
    /// Largest covariance eigenvalue over the white-noise edge (about 1 for noise alone).
    pub pulse_ratio: f64,
    /// The noise SD used (configured floor or the window's own estimate), N.
    pub noise_sd_n: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Classification {
    pub kind: Kind,
    /// In [0, 1].
    pub confidence: f64,
    pub features: Features,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ClassifyError {
    #[error("frame {seq} has a non-finite force or time")]
    NonFinite { seq: u64 },
    #[error("the window holds {have} frames; at least {need} are needed")]
    TooFew { have: usize, need: usize },
    #[error("invalid classifier parameters")]
    BadParams,
}

/// A sliding window of frames (a ring buffer sized once, at construction).
#[derive(Debug, Clone)]
pub struct Window {
    rows: Vec<[f64; ELEMENTS]>,
    head: usize,
    len: usize,
}

impl Window {
    /// A window of the last `capacity` frames (at least 3).
    pub fn new(capacity: usize) -> Self {
        Self {
            rows: vec![[0.0; ELEMENTS]; capacity.max(3)],
            head: 0,
            len: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn clear(&mut self) {
        self.len = 0;
        self.head = 0;
    }

    /// Add a frame; a non-finite frame is refused and the window is unchanged.
    pub fn push(&mut self, frame: &TactileFrame) -> Result<(), ClassifyError> {
        if !frame.is_finite() {
            return Err(ClassifyError::NonFinite { seq: frame.seq });
        }
        let cap = self.rows.len();
        self.rows[(self.head + self.len) % cap] = frame.force_n;
        if self.len < cap {
            self.len += 1;
        } else {
            self.head = (self.head + 1) % cap;
        }
        Ok(())
    }

    /// The i-th oldest frame's forces.
    fn row(&self, i: usize) -> &[f64; ELEMENTS] {
        &self.rows[(self.head + i) % self.rows.len()]
    }

    pub fn features(&self, params: &ClassifyParams) -> Result<Features, ClassifyError> {
        if !params.is_valid() {
            return Err(ClassifyError::BadParams);
        }
        if self.len < params.min_frames.max(3) {
            return Err(ClassifyError::TooFew {
                have: self.len,
                need: params.min_frames.max(3),
            });
        }
        Ok(window_features(
            self.len,
            |i| self.row(i),
            params.noise_sd_n,
            params.bin_frames,
        ))
    }

    /// Classify the window; `reference` is a previous artery's features under the same
    /// loading, against which a stenosis is judged.
    pub fn classify(
        &self,
        params: &ClassifyParams,
        reference: Option<&Features>,
    ) -> Result<Classification, ClassifyError> {
        Ok(classify_features(
            &self.features(params)?,
            params,
            reference,
        ))
    }
}

/// Reduce `n` frames (given by index, oldest first) to features; the covariance is taken over
/// bins of `m` frames (the oldest `n mod m` frames are left out of it).
fn window_features<'a>(
    n: usize,
    row: impl Fn(usize) -> &'a [f64; ELEMENTS],
    noise_floor_sd_n: f64,
    m: usize,
) -> Features {
    let nf = n as f64;
    let mut mean = [0.0; ELEMENTS];
    for i in 0..n {
        for (e, v) in row(i).iter().enumerate() {
            mean[e] += v;
        }
    }
    for v in &mut mean {
        *v /= nf;
    }
    let m = m.max(1);
    let nb = n / m;
    let skip = n - nb * m;
    let bin = |b: usize| -> [f64; ELEMENTS] {
        let mut out = [0.0; ELEMENTS];
        for i in skip + b * m..skip + (b + 1) * m {
            for (e, v) in row(i).iter().enumerate() {
                out[e] += v;
            }
        }
        for v in &mut out {
            *v /= m as f64;
        }
        out
    };
    // Per-element linear trend over the bins (slow drift of the contact is not a pulse).
    let nbf = nb as f64;
    let t_mean = 0.5 * (nbf - 1.0);
    let mut bmean = [0.0; ELEMENTS];
    let mut tx = [0.0; ELEMENTS];
    let mut tt = 0.0;
    for b in 0..nb {
        let t = b as f64 - t_mean;
        tt += t * t;
        for (e, v) in bin(b).iter().enumerate() {
            bmean[e] += v;
            tx[e] += t * v;
        }
    }
    let mut slope = [0.0; ELEMENTS];
    for e in 0..ELEMENTS {
        bmean[e] /= nbf;
        slope[e] = if tt > 0.0 { tx[e] / tt } else { 0.0 };
    }
    let mut cov = [[0.0; ELEMENTS]; ELEMENTS];
    for b in 0..nb {
        let t = b as f64 - t_mean;
        let mut r = [0.0; ELEMENTS];
        for (e, v) in bin(b).iter().enumerate() {
            r[e] = v - bmean[e] - slope[e] * t;
        }
        for a in 0..ELEMENTS {
            for c in a..ELEMENTS {
                cov[a][c] += r[a] * r[c];
            }
        }
    }
    let dof = (nbf - 2.0).max(1.0);
    for a in 0..ELEMENTS {
        for c in a..ELEMENTS {
            cov[a][c] /= dof;
            cov[c][a] = cov[a][c];
        }
    }
    let (lambda, v) = dominant_eigen(&cov);
    let trace: f64 = (0..ELEMENTS).map(|e| cov[e][e]).sum();
    let p = ELEMENTS as f64;
    // Noise variance of one bin: the window's own estimate or the configured floor.
    let floor_var = noise_floor_sd_n * noise_floor_sd_n / m as f64;
    let noise_var = ((trace - lambda) / (p - 1.0)).max(floor_var);
    let edge = (1.0 + (p / nbf.max(1.0)).sqrt()).powi(2);
    let pulse_ratio = lambda / (noise_var * edge);
    let amp = (lambda - noise_var).max(0.0).sqrt() * 2.0 * std::f64::consts::SQRT_2;
    let mut swing_element = 0;
    for e in 0..ELEMENTS {
        if v[e].abs() > v[swing_element].abs() {
            swing_element = e;
        }
    }
    let sign = if v[swing_element] < 0.0 { -1.0 } else { 1.0 };
    let mut swing_n = [0.0; ELEMENTS];
    for e in 0..ELEMENTS {
        swing_n[e] = sign * v[e] * amp;
    }
    let mut peak_element = 0;
    let mut lo = f64::INFINITY;
    for e in 0..ELEMENTS {
        if mean[e] > mean[peak_element] {
            peak_element = e;
        }
        lo = lo.min(mean[e]);
    }
    Features {
        frames: n,
        mean_n: mean,
        peak_n: mean[peak_element],
        peak_element,
        static_contrast_n: mean[peak_element] - lo,
        swing_n,
        swing_peak_n: swing_n[swing_element].abs(),
        swing_element,
        pulse_ratio,
        noise_sd_n: (noise_var * m as f64).sqrt(),
    }
}

/// Largest eigenvalue and unit eigenvector of a symmetric positive semi-definite matrix, by
/// power iteration from a fixed start (deterministic).
fn dominant_eigen(a: &[[f64; ELEMENTS]; ELEMENTS]) -> (f64, [f64; ELEMENTS]) {
    let mut v = [1.0 / (ELEMENTS as f64).sqrt(); ELEMENTS];
    // Start along the largest diagonal as well, so a mode orthogonal to all-ones is found.
    let mut big = 0;
    for e in 0..ELEMENTS {
        if a[e][e] > a[big][big] {
            big = e;
        }
    }
    v[big] += 1.0;
    let mut lambda = 0.0;
    for _ in 0..500 {
        let mut w = [0.0; ELEMENTS];
        for r in 0..ELEMENTS {
            for c in 0..ELEMENTS {
                w[r] += a[r][c] * v[c];
            }
        }
        let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm.is_nan() || norm <= 0.0 || !norm.is_finite() {
            return (0.0, v);
        }
        for x in &mut w {
            *x /= norm;
        }
        let diff: f64 = w.iter().zip(&v).map(|(a, b)| (a - b).abs()).sum();
        v = w;
        let prev = lambda;
        lambda = norm;
        if diff < 1e-12 || (lambda - prev).abs() <= 1e-14 * lambda {
            break;
        }
    }
    (lambda, v)
}

/// Logistic confidence that `x` is above `threshold`, with transition width `scale`.
fn above(x: f64, threshold: f64, scale: f64) -> f64 {
    1.0 / (1.0 + (-(x - threshold) / scale).exp())
}

/// Table 2 applied to features.
pub fn classify_features(
    f: &Features,
    params: &ClassifyParams,
    reference: Option<&Features>,
) -> Classification {
    // Time-varying: the coherent variance clears the noise edge.
    let p_pulse = above(f.pulse_ratio, params.pulse_ratio, 0.05 * params.pulse_ratio);
    // Non-uniform: the static contrast clears the tolerance by several standard errors.
    let level = f.mean_n.iter().sum::<f64>() / ELEMENTS as f64;
    let tolerance = params.uniform_tolerance_n + params.uniform_tolerance_rel * level.abs();
    let se = f.noise_sd_n / (f.frames as f64).sqrt();
    let p_peak = above((f.static_contrast_n - tolerance) / se.max(1e-30), 4.0, 1.0);
    let (kind, confidence) = if p_pulse >= 0.5 {
        match reference {
            Some(r) if r.pulse_ratio >= params.pulse_ratio => {
                let m = params.stenosis_margin;
                // Larger peak and smaller swing than the reference artery.
                let peak_gain = (f.peak_n - r.peak_n) / r.peak_n.abs().max(1e-12);
                let swing_loss = (r.swing_peak_n - f.swing_peak_n) / r.swing_peak_n.max(1e-12);
                let p_larger = above(peak_gain, m, 0.3 * m.max(1e-3));
                let p_smaller = above(swing_loss, m, 0.3 * m.max(1e-3));
                let p_sten = p_larger * p_smaller;
                if p_sten >= 0.5 {
                    (Kind::ArteryStenosisSuspected, p_pulse * p_sten)
                } else {
                    (Kind::Artery, p_pulse * (1.0 - p_sten))
                }
            }
            _ => (Kind::Artery, p_pulse),
        }
    } else if p_peak >= 0.5 {
        (Kind::Lump, (1.0 - p_pulse) * p_peak)
    } else {
        (Kind::Tissue, (1.0 - p_pulse) * (1.0 - p_peak))
    };
    Classification {
        kind,
        confidence,
        features: *f,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic Gaussian-ish noise (sum of 12 uniforms) from a xorshift generator.
    struct Noise(u64);
    impl Noise {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn normal(&mut self) -> f64 {
            (0..12).map(|_| self.uniform()).sum::<f64>() - 6.0
        }
    }

    /// 4 s at 100 Hz of `static + pulse(t) * pattern + noise`.
    fn window(
        static_n: impl Fn(usize) -> f64,
        pattern: impl Fn(usize) -> f64,
        pulse_amp: f64,
        sd: f64,
        seed: u64,
    ) -> Window {
        let mut w = Window::new(400);
        let mut rng = Noise(seed);
        for i in 0..400 {
            let t = i as f64 * 0.01;
            // Triangular 1.2 Hz pulse between 0 and 1.
            let ph = (t * 1.2).fract();
            let s = if ph < 0.5 { 2.0 * ph } else { 2.0 - 2.0 * ph };
            let mut force = [0.0; ELEMENTS];
            for (e, f) in force.iter_mut().enumerate() {
                *f = static_n(e) + pulse_amp * s * pattern(e) + sd * rng.normal();
            }
            w.push(&TactileFrame {
                t_s: t,
                seq: i as u64,
                force_n: force,
            })
            .unwrap();
        }
        w
    }

    fn bump(e: usize, centre: f64, width: f64) -> f64 {
        let d = (e as f64 - centre) / width;
        (-d * d).exp()
    }

    #[test]
    fn the_four_kinds_follow_table_2() {
        let p = ClassifyParams::default();
        let tissue = window(|_| 0.5, |_| 0.0, 0.0, 0.012, 1)
            .classify(&p, None)
            .unwrap();
        assert_eq!(tissue.kind, Kind::Tissue, "{tissue:?}");
        assert!(tissue.confidence > 0.8);

        let lump = window(|e| 0.5 + 0.2 * bump(e, 4.0, 1.5), |_| 0.0, 0.0, 0.012, 2)
            .classify(&p, None)
            .unwrap();
        assert_eq!(lump.kind, Kind::Lump, "{lump:?}");
        assert_eq!(lump.features.peak_element, 4);

        // A pulse of 0.025 N peak to peak, about twice the 0.012 N noise SD, on elements 5-6.
        let artery = window(
            |e| 0.5 + 0.05 * bump(e, 5.5, 1.5),
            |e| bump(e, 5.5, 1.5) - 0.3,
            0.025,
            0.012,
            3,
        )
        .classify(&p, None)
        .unwrap();
        assert_eq!(artery.kind, Kind::Artery, "{artery:?}");
        assert!(matches!(artery.features.swing_element, 5 | 6));
        // Out-of-phase flanks keep their sign relative to the peak.
        assert!(artery.features.swing_n[0] < 0.0 && artery.features.swing_n[5] > 0.0);

        let stenotic = window(
            |e| 0.5 + 0.09 * bump(e, 5.5, 1.5),
            |e| bump(e, 5.5, 1.5) - 0.3,
            0.015,
            0.012,
            4,
        )
        .classify(&p, Some(&artery.features))
        .unwrap();
        assert_eq!(stenotic.kind, Kind::ArteryStenosisSuspected, "{stenotic:?}");
        // The healthy one compared with the stenotic one is not stenotic.
        let back = classify_features(&artery.features, &p, Some(&stenotic.features));
        assert_eq!(back.kind, Kind::Artery);
    }

    #[test]
    fn noise_alone_is_never_a_pulse() {
        let p = ClassifyParams::default();
        let mut worst: f64 = 0.0;
        for seed in 10..60 {
            let c = window(|_| 0.3, |_| 0.0, 0.0, 0.012, seed)
                .classify(&p, None)
                .unwrap();
            worst = worst.max(c.features.pulse_ratio);
            assert_eq!(
                c.kind,
                Kind::Tissue,
                "seed {seed}: {:?}",
                c.features.pulse_ratio
            );
        }
        // The statistic sits near 1 for noise: the threshold has a margin above it.
        assert!(
            worst > 0.8 && worst < 0.9 * p.pulse_ratio,
            "worst ratio {worst}"
        );
    }

    #[test]
    fn slow_drift_is_not_a_pulse() {
        let p = ClassifyParams::default();
        let mut w = Window::new(400);
        let mut rng = Noise(7);
        for i in 0..400 {
            let mut force = [0.0; ELEMENTS];
            for f in &mut force {
                *f = 0.3 + 0.0005 * i as f64 + 0.012 * rng.normal();
            }
            w.push(&TactileFrame {
                t_s: i as f64 * 0.01,
                seq: i,
                force_n: force,
            })
            .unwrap();
        }
        assert_eq!(w.classify(&p, None).unwrap().kind, Kind::Tissue);
    }

    #[test]
    fn bad_input_is_an_error() {
        let p = ClassifyParams::default();
        let mut w = Window::new(200);
        let bad = TactileFrame {
            t_s: 0.0,
            seq: 9,
            force_n: [f64::NAN; ELEMENTS],
        };
        assert_eq!(w.push(&bad), Err(ClassifyError::NonFinite { seq: 9 }));
        assert!(w.is_empty());
        assert!(matches!(
            w.classify(&p, None),
            Err(ClassifyError::TooFew { have: 0, .. })
        ));
        let bad_params = ClassifyParams {
            pulse_ratio: 0.5,
            ..p
        };
        assert_eq!(w.features(&bad_params), Err(ClassifyError::BadParams));
    }

    #[test]
    fn the_ring_buffer_keeps_the_latest_frames() {
        let mut w = Window::new(3);
        for i in 0..5u64 {
            let mut f = [0.0; ELEMENTS];
            f[0] = i as f64;
            w.push(&TactileFrame {
                t_s: i as f64,
                seq: i,
                force_n: f,
            })
            .unwrap();
        }
        assert_eq!(w.len(), 3);
        assert_eq!([w.row(0)[0], w.row(1)[0], w.row(2)[0]], [2.0, 3.0, 4.0]);
    }
}
