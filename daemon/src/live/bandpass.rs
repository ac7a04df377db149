//! The tactile frames through the tracker's band-pass as they arrive, and each element's
//! pulse swing, for the live view.
//!
//! The taps are `control::signal::BandPass`'s (the `seed2002` tracker's filter, designed from
//! the configured order and corners at the array's rate); here they run as a streaming FIR
//! over the newest `order + 1` frames. The filter is symmetric, so its output for the window
//! is exactly the zero-phase value at the window's centre: each output is stamped with the
//! time of the frame `order / 2` samples back (it lines up with the raw trace) and arrives
//! that much later. Its taps sum to zero and are symmetric, so the contact offset and a linear
//! drift vanish without the detrending the tracker's whole-window filter needs at its ends.
//! A gap in the frame sequence (a dropped frame, a reconnect) restarts the filter.

use std::collections::VecDeque;

use control::signal::{BandPass, BandPassSpec, FilterDesignError};
use control::types::ELEMENTS;

use crate::live::beats::{beat_times, spacing_s};
use crate::live::messages::{BandPassedFrame, PulseSample};

#[derive(Debug, Clone, Copy)]
struct Raw {
    t_s: f64,
    seq: u64,
    force_n: [f64; ELEMENTS],
}

/// The streaming filter and the swing window behind it.
#[derive(Debug)]
pub struct LiveBandPass {
    taps: Vec<f64>,
    delay_s: f64,
    raw: VecDeque<Raw>,
    /// Band-passed samples of the last `window` frames (time s, force N), for the swing.
    filtered: VecDeque<(f64, [f64; ELEMENTS])>,
    window: usize,
    window_s: f64,
}

impl LiveBandPass {
    /// The band of `spec`; the swing is taken over `window_s`.
    pub fn new(spec: BandPassSpec, window_s: f64) -> Result<Self, FilterDesignError> {
        let filter = BandPass::design(spec)?;
        let window = ((window_s * spec.sample_rate_hz).round() as usize).max(2);
        Ok(Self {
            delay_s: filter.delay_samples() as f64 / spec.sample_rate_hz,
            taps: filter.taps().to_vec(),
            raw: VecDeque::with_capacity(spec.order + 2),
            filtered: VecDeque::with_capacity(window + 1),
            window,
            window_s,
        })
    }

    /// How late a band-passed sample is, s.
    pub fn delay_s(&self) -> f64 {
        self.delay_s
    }

    /// Add a raw frame; the band-passed sample it completes, if any.
    pub fn push(
        &mut self,
        t_s: f64,
        seq: u64,
        force_n: &[f64; ELEMENTS],
    ) -> Option<BandPassedFrame> {
        let contiguous = self
            .raw
            .back()
            .is_none_or(|last| seq == last.seq.wrapping_add(1));
        if !contiguous || !force_n.iter().all(|f| f.is_finite()) || !t_s.is_finite() {
            self.raw.clear();
            self.filtered.clear();
            if !force_n.iter().all(|f| f.is_finite()) {
                return None;
            }
        }
        self.raw.push_back(Raw {
            t_s,
            seq,
            force_n: *force_n,
        });
        if self.raw.len() > self.taps.len() {
            self.raw.pop_front();
        }
        if self.raw.len() < self.taps.len() {
            return None;
        }
        let mut out = [0.0; ELEMENTS];
        // Symmetric taps: the order of the window does not matter.
        for (h, frame) in self.taps.iter().zip(self.raw.iter()) {
            for (o, f) in out.iter_mut().zip(frame.force_n.iter()) {
                *o += h * f;
            }
        }
        let centre = self.raw.get(self.taps.len() / 2)?;
        self.filtered.push_back((centre.t_s, out));
        if self.filtered.len() > self.window {
            self.filtered.pop_front();
        }
        Some(BandPassedFrame {
            t_s: centre.t_s,
            seq: centre.seq,
            force_n: out,
            delay_s: self.delay_s,
        })
    }

    /// Each element's peak-to-peak over the swing window, once the window is full.
    pub fn pulse(&self, t_s: f64, period_s: Option<f64>) -> Option<PulseSample> {
        if self.filtered.len() < self.window {
            return None;
        }
        let mut lo = [f64::INFINITY; ELEMENTS];
        let mut hi = [f64::NEG_INFINITY; ELEMENTS];
        for (_, s) in &self.filtered {
            for e in 0..ELEMENTS {
                lo[e] = lo[e].min(s[e]);
                hi[e] = hi[e].max(s[e]);
            }
        }
        let amplitude_n: [f64; ELEMENTS] = std::array::from_fn(|e| hi[e] - lo[e]);
        let strongest_element = amplitude_n
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, _)| i)
            .unwrap_or(0);
        let trace: Vec<(f64, f64)> = self
            .filtered
            .iter()
            .map(|(t, f)| (*t, f[strongest_element]))
            .collect();
        Some(PulseSample {
            t_s,
            period_s,
            amplitude_n,
            window_s: self.window_s,
            strongest_element,
            beat_times_s: beat_times(&trace, spacing_s(period_s)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 100.0;

    fn spec() -> BandPassSpec {
        BandPassSpec {
            order: 96,
            low_hz: 0.5,
            high_hz: 2.0,
            sample_rate_hz: FS,
        }
    }

    /// A 1 Hz pulse of `amp` N on element 3, on a 2 N contact with drift, on every element.
    fn frame(i: u64, amp: f64) -> [f64; ELEMENTS] {
        let t = i as f64 / FS;
        std::array::from_fn(|e| {
            let pulse = if e == 3 {
                amp * (2.0 * std::f64::consts::PI * t).sin()
            } else {
                0.0
            };
            2.0 + 0.05 * t + pulse
        })
    }

    #[test]
    fn passes_the_pulse_in_phase_and_removes_contact_and_drift() {
        let mut bp = LiveBandPass::new(spec(), 2.0).expect("design");
        assert!((bp.delay_s() - 0.48).abs() < 1e-12);
        let mut outs = Vec::new();
        for i in 0..1000 {
            if let Some(o) = bp.push(i as f64 / FS, i, &frame(i, 0.1)) {
                outs.push(o);
            }
        }
        assert_eq!(outs.len(), 1000 - 96);
        // Stamped at the centre frame: in phase with the raw pulse, at unit gain near 1 Hz.
        for o in &outs[200..] {
            let want = 0.1 * (2.0 * std::f64::consts::PI * o.t_s).sin();
            assert!(
                (o.force_n[3] - want).abs() < 0.01,
                "{} vs {want}",
                o.force_n[3]
            );
            assert!(
                o.force_n[0].abs() < 1e-9,
                "offset and drift pass: {}",
                o.force_n[0]
            );
            assert_eq!(o.seq as f64, (o.t_s * FS).round());
        }
        let p = bp.pulse(10.0, Some(1.0)).expect("window full");
        assert_eq!(p.strongest_element, 3);
        assert!((p.amplitude_n[3] - 0.2).abs() < 0.02, "{:?}", p.amplitude_n);
        assert!(p.amplitude_n[0] < 1e-9);
        // The 1 Hz sine peaks at t = k + 0.25; the 2 s window ends at frame 999's centre, so its peak at 8.25 s is confirmed.
        assert!(!p.beat_times_s.is_empty(), "{p:?}");
        for t in &p.beat_times_s {
            assert!(((t - 0.25) - (t - 0.25).round()).abs() < 0.011, "{p:?}");
        }
    }

    #[test]
    fn a_gap_or_a_non_finite_frame_restarts_the_filter() {
        let mut bp = LiveBandPass::new(spec(), 1.0).expect("design");
        for i in 0..97 {
            bp.push(i as f64 / FS, i, &frame(i, 0.1));
        }
        assert!(bp.push(0.97, 97, &frame(97, 0.1)).is_some());
        // Frame 99 follows 97: a dropped frame.
        assert!(bp.push(0.99, 99, &frame(99, 0.1)).is_none());
        assert!(bp.pulse(1.0, None).is_none());
        let mut bad = frame(100, 0.1);
        bad[2] = f64::NAN;
        assert!(bp.push(1.0, 100, &bad).is_none());
        let n = (101..300)
            .filter_map(|i| bp.push(i as f64 / FS, i, &frame(i, 0.1)))
            .count();
        assert_eq!(n, 199 - 96);
    }

    #[test]
    fn a_bad_band_is_refused() {
        let mut s = spec();
        s.order = 3;
        assert!(LiveBandPass::new(s, 1.0).is_err());
    }
}
