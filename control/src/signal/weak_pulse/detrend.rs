//! Each element's static load and slow drift taken out, and its noise measured.
//!
//! A lump is a static force pattern and tissue drift is slow; the pulse repeats at 0.6 Hz or
//! faster. A centred moving average of a moving average over `len` samples (a triangle 2 `len`
//! wide; `len` about 2 s, longer than the slowest beat) follows both and is subtracted: a
//! constant or a linear drift leaves nothing, a curved drift a residue far below the pulse's
//! band. Its response is `1 - sinc²(f L)`, between 0.95 and 1 at every rate above 0.6 Hz
//! with L = 2 s. Why twice: a single average's response, `1 - sinc(f L)`, swings above 1
//! where its sidelobe is negative (up to 1.21 at 0.75 Hz), so the noise left at those rates
//! had up to 15 % more variance than the white noise the likelihood ratio assumes
//! (measured per trial rate on unit noise), and the statistic drifted upward under noise
//! alone: its thresholds grew with the window past what a mean-one ratio needs. Squared, the
//! sidelobe never amplifies. The output lags the input by `len - 1` samples.
//!
//! The noise SD comes from consecutive raw samples' differences (`E[(Δy)²] = 2σ²` for white
//! noise): a static lump and a slow drift add nothing to them, nor does a pulse far below
//! the noise, so the detector's statistic is scaled by the data's own noise.

use crate::types::ELEMENTS;

#[derive(Clone)]
pub(super) struct Detrend {
    /// The last `2 len - 1` samples and their times; `head` is where the next goes.
    ring: Vec<[f64; ELEMENTS]>,
    times: Vec<f64>,
    /// The last `len` running sums of `len` samples.
    sums: Vec<[f64; ELEMENTS]>,
    len: usize,
    head: usize,
    sum_head: usize,
    filled: usize,
    /// Σ of the last `len` samples, and Σ of the last `len` such sums.
    sum: [f64; ELEMENTS],
    sum2: [f64; ELEMENTS],
    since_resum: usize,
    last: Option<[f64; ELEMENTS]>,
    diff_sq: [f64; ELEMENTS],
    diffs: usize,
}

impl Detrend {
    /// `len` is made odd so that the average is centred on a sample.
    pub(super) fn new(len: usize) -> Self {
        let len = len.max(3) | 1;
        Self {
            ring: vec![[0.0; ELEMENTS]; 2 * len - 1],
            times: vec![0.0; 2 * len - 1],
            sums: vec![[0.0; ELEMENTS]; len],
            len,
            head: 0,
            sum_head: 0,
            filled: 0,
            sum: [0.0; ELEMENTS],
            sum2: [0.0; ELEMENTS],
            since_resum: 0,
            last: None,
            diff_sq: [0.0; ELEMENTS],
            diffs: 0,
        }
    }

    /// Take one frame; `contiguous` is false after a gap (the averages restart). Returns the
    /// detrended frame `len - 1` samples back, once the averages are full.
    pub(super) fn push(
        &mut self,
        t_s: f64,
        y: &[f64; ELEMENTS],
        contiguous: bool,
    ) -> Option<(f64, [f64; ELEMENTS])> {
        if !contiguous {
            self.filled = 0;
            self.sum = [0.0; ELEMENTS];
            self.sum2 = [0.0; ELEMENTS];
            self.sums.iter_mut().for_each(|v| *v = [0.0; ELEMENTS]);
            self.sum_head = 0;
            self.last = None;
        }
        if let Some(last) = self.last {
            for ((d, a), b) in self.diff_sq.iter_mut().zip(y).zip(&last) {
                *d += (a - b).powi(2);
            }
            self.diffs += 1;
        }
        self.last = Some(*y);
        let (len, n) = (self.len, self.ring.len());
        // The sample leaving the first average is `len` back.
        if self.filled >= len {
            let old = self.ring[(self.head + n - len) % n];
            for (s, o) in self.sum.iter_mut().zip(&old) {
                *s -= o;
            }
        }
        self.ring[self.head] = *y;
        self.times[self.head] = t_s;
        for (s, v) in self.sum.iter_mut().zip(y) {
            *s += v;
        }
        self.head = (self.head + 1) % n;
        self.filled = (self.filled + 1).min(n);
        self.since_resum += 1;
        if self.since_resum >= n {
            // Re-add from scratch now and then so rounding cannot build up over hours.
            self.since_resum = 0;
            self.sum = [0.0; ELEMENTS];
            for k in 0..self.filled.min(len) {
                let r = self.ring[(self.head + n - 1 - k) % n];
                for (s, v) in self.sum.iter_mut().zip(&r) {
                    *s += v;
                }
            }
        }
        if self.filled < len {
            return None;
        }
        // The second average, over the first's last `len` values.
        let oldest = self.sums[self.sum_head];
        let full = self.filled >= n;
        for ((s2, o), s1) in self.sum2.iter_mut().zip(&oldest).zip(&self.sum) {
            if full {
                *s2 -= o;
            }
            *s2 += s1;
        }
        self.sums[self.sum_head] = self.sum;
        self.sum_head = (self.sum_head + 1) % len;
        if self.since_resum == 0 {
            self.sum2 = [0.0; ELEMENTS];
            let count = if full { len } else { self.filled - len + 1 };
            for k in 0..count {
                let r = self.sums[(self.sum_head + len - 1 - k) % len];
                for (s, v) in self.sum2.iter_mut().zip(&r) {
                    *s += v;
                }
            }
        }
        if !full {
            return None;
        }
        let centre = (self.head + n - len) % n;
        let c = self.ring[centre];
        let w = (len * len) as f64;
        let out = std::array::from_fn(|e| c[e] - self.sum2[e] / w);
        Some((self.times[centre], out))
    }

    /// Each element's noise SD so far (0 before two samples, or on a flat element).
    pub(super) fn noise_sd(&self) -> [f64; ELEMENTS] {
        if self.diffs == 0 {
            return [0.0; ELEMENTS];
        }
        std::array::from_fn(|e| (self.diff_sq[e] / (2.0 * self.diffs as f64)).sqrt())
    }
}
