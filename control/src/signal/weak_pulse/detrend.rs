//! Each element's static load and slow drift taken out, and its noise measured.
//!
//! A lump is a static force pattern and tissue drift is slow; the pulse repeats at 0.6 Hz or
//! faster. A centred moving average over `len` samples (about 2 s, longer than the slowest
//! beat) follows both and is subtracted: a constant or a linear drift leaves nothing, a
//! curved drift a residue far below the pulse's band, and the pulse's fundamental is changed
//! by at most the average's small sidelobe (`1 - sinc(f L)`, under 16 % at 0.6 Hz and 2 s).
//! The output lags the input by half the average.
//!
//! The noise SD comes from consecutive raw samples' differences (`E[(Δy)²] = 2σ²` for white
//! noise): a static lump and a slow drift add nothing to them, nor does a pulse far below
//! the noise, so the detector's statistic is scaled by the data's own noise.

use crate::types::ELEMENTS;

#[derive(Clone)]
pub(super) struct Detrend {
    ring: Vec<[f64; ELEMENTS]>,
    times: Vec<f64>,
    head: usize,
    filled: usize,
    sum: [f64; ELEMENTS],
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
            ring: vec![[0.0; ELEMENTS]; len],
            times: vec![0.0; len],
            head: 0,
            filled: 0,
            sum: [0.0; ELEMENTS],
            since_resum: 0,
            last: None,
            diff_sq: [0.0; ELEMENTS],
            diffs: 0,
        }
    }

    /// Take one frame; `contiguous` is false after a gap (the average restarts). Returns the
    /// detrended frame `len / 2` samples back, once the average is full.
    pub(super) fn push(
        &mut self,
        t_s: f64,
        y: &[f64; ELEMENTS],
        contiguous: bool,
    ) -> Option<(f64, [f64; ELEMENTS])> {
        if !contiguous {
            self.filled = 0;
            self.sum = [0.0; ELEMENTS];
            self.last = None;
        }
        if let Some(last) = self.last {
            for ((d, a), b) in self.diff_sq.iter_mut().zip(y).zip(&last) {
                *d += (a - b).powi(2);
            }
            self.diffs += 1;
        }
        self.last = Some(*y);
        let len = self.ring.len();
        if self.filled == len {
            let old = self.ring[self.head];
            for (s, o) in self.sum.iter_mut().zip(&old) {
                *s -= o;
            }
        } else {
            self.filled += 1;
        }
        self.ring[self.head] = *y;
        self.times[self.head] = t_s;
        for (s, v) in self.sum.iter_mut().zip(y) {
            *s += v;
        }
        self.head = (self.head + 1) % len;
        self.since_resum += 1;
        if self.since_resum >= len {
            // Re-add from scratch now and then so rounding cannot build up over hours.
            self.since_resum = 0;
            self.sum = [0.0; ELEMENTS];
            for k in 0..self.filled {
                let r = self.ring[(self.head + len - 1 - k) % len];
                for (s, v) in self.sum.iter_mut().zip(&r) {
                    *s += v;
                }
            }
        }
        if self.filled < len {
            return None;
        }
        let centre = (self.head + len / 2) % len;
        let c = self.ring[centre];
        let out = std::array::from_fn(|e| c[e] - self.sum[e] / len as f64);
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
