//! A fixed-capacity acquisition window: consecutive tactile frames, stored per element.
//!
//! The buffer is allocated once; filling it never allocates. Frames must be consecutive
//! (sequence numbers without gaps, increasing times, finite forces): the filter and the
//! pulse timing assume uniform sampling, so a window with a hole in it is not analysed.
//! Times inside the window are the first frame's time plus the sample index times the
//! nominal sampling interval.

use crate::types::{ELEMENTS, TactileFrame};

/// Why a frame could not be added to the window. The caller restarts the window.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum FrameProblem {
    #[error("frame {seq} at t = {t_s} s has a non-finite time or force")]
    NonFinite { seq: u64, t_s: f64 },
    #[error("frame {seq} does not follow frame {previous}: frames were dropped or reordered")]
    SequenceGap { previous: u64, seq: u64 },
    #[error("frame {seq} at t = {t_s} s is not later than the previous frame at {previous_t_s} s")]
    TimeNotIncreasing {
        seq: u64,
        t_s: f64,
        previous_t_s: f64,
    },
}

/// Samples of every element over one acquisition.
#[derive(Debug, Clone)]
pub struct AcquisitionWindow {
    capacity: usize,
    target: usize,
    len: usize,
    dt_s: f64,
    t_first_s: f64,
    last: Option<(u64, f64)>,
    /// Element-major: element `e`'s samples are `data[e * capacity ..][..len]`.
    data: Vec<f64>,
}

/// Read access to per-element series of equal length.
#[derive(Debug, Clone, Copy)]
pub struct Channels<'a> {
    data: &'a [f64],
    stride: usize,
    len: usize,
}

impl<'a> Channels<'a> {
    /// `data` holds `ELEMENTS` series of `len` samples, each starting `stride` apart.
    /// Returns `None` if `data` is too short for that layout or `len > stride`.
    pub fn new(data: &'a [f64], stride: usize, len: usize) -> Option<Self> {
        let needed = stride.checked_mul(ELEMENTS - 1)?.checked_add(len)?;
        (len <= stride && data.len() >= needed).then_some(Self { data, stride, len })
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The first `len` samples of each series (all of them if `len` is larger).
    pub fn truncated(&self, len: usize) -> Self {
        Self {
            len: len.min(self.len),
            ..*self
        }
    }

    /// The samples of element `e` (`e < ELEMENTS`).
    pub fn element(&self, e: usize) -> &'a [f64] {
        let start = e.min(ELEMENTS - 1) * self.stride;
        &self.data[start..start + self.len]
    }
}

impl AcquisitionWindow {
    /// A window able to hold up to `capacity_samples` frames at `sample_rate_hz`.
    pub fn new(capacity_samples: usize, sample_rate_hz: f64) -> Self {
        let capacity = capacity_samples.max(1);
        Self {
            capacity,
            target: capacity,
            len: 0,
            dt_s: 1.0 / sample_rate_hz,
            t_first_s: 0.0,
            last: None,
            data: vec![0.0; capacity * ELEMENTS],
        }
    }

    /// Empty the window and aim to collect `samples` frames (at most the capacity).
    pub fn begin(&mut self, samples: usize) {
        self.target = samples.clamp(1, self.capacity);
        self.clear();
    }

    /// Empty the window, keeping its target length.
    pub fn clear(&mut self) {
        self.len = 0;
        self.last = None;
    }

    /// Add a frame. A frame that breaks uniform sampling empties the window and is
    /// reported: after a gap or a time step back it starts the new window, a non-finite
    /// frame is dropped. Frames beyond the target are ignored.
    pub fn push(&mut self, frame: &TactileFrame) -> Result<(), FrameProblem> {
        if !frame.is_finite() {
            self.clear();
            return Err(FrameProblem::NonFinite {
                seq: frame.seq,
                t_s: frame.t_s,
            });
        }
        let problem = match self.last {
            Some((previous, _)) if previous.checked_add(1) != Some(frame.seq) => {
                Some(FrameProblem::SequenceGap {
                    previous,
                    seq: frame.seq,
                })
            }
            Some((_, previous_t_s)) if frame.t_s <= previous_t_s => {
                Some(FrameProblem::TimeNotIncreasing {
                    seq: frame.seq,
                    t_s: frame.t_s,
                    previous_t_s,
                })
            }
            _ => None,
        };
        if problem.is_some() {
            self.clear();
        } else if self.is_full() {
            self.last = Some((frame.seq, frame.t_s));
            return Ok(());
        }
        if self.len == 0 {
            self.t_first_s = frame.t_s;
        }
        for (e, f) in frame.force_n.iter().enumerate() {
            self.data[e * self.capacity + self.len] = *f;
        }
        self.len += 1;
        self.last = Some((frame.seq, frame.t_s));
        problem.map_or(Ok(()), Err)
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// The window holds its target number of frames.
    pub fn is_full(&self) -> bool {
        self.len >= self.target
    }

    /// Nominal sampling interval, s.
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// Time of the first sample, s.
    pub fn t_first_s(&self) -> f64 {
        self.t_first_s
    }

    /// Time of (possibly fractional) sample index `i`, s.
    pub fn time_of(&self, i: f64) -> f64 {
        self.t_first_s + i * self.dt_s
    }

    /// The raw samples collected so far.
    pub fn channels(&self) -> Channels<'_> {
        Channels {
            data: &self.data,
            stride: self.capacity,
            len: self.len,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(seq: u64, value: f64) -> TactileFrame {
        TactileFrame {
            t_s: seq as f64 * 0.01,
            seq,
            force_n: std::array::from_fn(|e| value + e as f64),
        }
    }

    #[test]
    fn fills_per_element_and_stops_at_target() {
        let mut w = AcquisitionWindow::new(5, 100.0);
        w.begin(3);
        for s in 10..15 {
            w.push(&frame(s, s as f64)).expect("consecutive");
        }
        assert!(w.is_full());
        assert_eq!(w.len(), 3);
        assert_eq!(w.channels().element(2), &[12.0, 13.0, 14.0]);
        assert!((w.time_of(1.5) - 0.115).abs() < 1e-12);
    }

    #[test]
    fn gaps_and_bad_frames_restart_the_window() {
        let mut w = AcquisitionWindow::new(5, 100.0);
        w.push(&frame(1, 0.0)).expect("first");
        assert!(matches!(
            w.push(&frame(3, 0.0)),
            Err(FrameProblem::SequenceGap {
                previous: 1,
                seq: 3
            })
        ));
        assert_eq!(w.len(), 1, "the frame after the gap starts the new window");
        w.push(&frame(4, 0.0)).expect("continues");
        let mut bad = frame(5, 0.0);
        bad.force_n[7] = f64::NAN;
        assert!(matches!(w.push(&bad), Err(FrameProblem::NonFinite { .. })));
        assert!(w.is_empty());
        w.push(&frame(6, 0.0)).expect("restart");
        let mut early = frame(7, 0.0);
        early.t_s = 0.0;
        assert!(matches!(
            w.push(&early),
            Err(FrameProblem::TimeNotIncreasing { .. })
        ));
    }
}
