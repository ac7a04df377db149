//! The last few seconds of frames with where the robot believed the sensor was at each, and
//! which way the sensor then trailed behind that belief, and how far the arm's load put
//! it from that belief (where the rod is described).
//!
//! `beatslide` analyses windows that end now and reach back one beat or more, while the
//! sensor slides; a fix needs the forces, the believed positions and the lag directions of
//! the same frames. A ring buffer allocated once; windows are read as two contiguous
//! slices.

use crate::frames::SurfacePoint;
use crate::types::TactileFrame;

#[derive(Debug, Clone)]
pub struct History {
    frames: Vec<TactileFrame>,
    sensors: Vec<SurfacePoint>,
    lags: Vec<[f64; 2]>,
    /// Where the arm's load put the sensor less where it was believed, m; NaN where the
    /// rod is not described.
    felt: Vec<[f64; 2]>,
    capacity: usize,
    /// Index of the oldest entry.
    head: usize,
    len: usize,
}

impl History {
    pub fn new(capacity: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            frames: Vec::with_capacity(capacity),
            sensors: Vec::with_capacity(capacity),
            lags: Vec::with_capacity(capacity),
            felt: Vec::with_capacity(capacity),
            capacity,
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
        self.frames.clear();
        self.sensors.clear();
        self.lags.clear();
        self.felt.clear();
        self.head = 0;
        self.len = 0;
    }

    /// Append; the oldest entry goes once the buffer is full. `loaded` is where the arm's
    /// load says the sensor is, if known.
    pub fn push(
        &mut self,
        frame: TactileFrame,
        sensor: SurfacePoint,
        lag: [f64; 2],
        loaded: Option<SurfacePoint>,
    ) {
        let felt = loaded
            .filter(|l| l.is_finite())
            .map_or([f64::NAN; 2], |l| [l.x_m - sensor.x_m, l.z_m - sensor.z_m]);
        if self.frames.len() < self.capacity {
            self.frames.push(frame);
            self.sensors.push(sensor);
            self.lags.push(lag);
            self.felt.push(felt);
            self.len += 1;
            return;
        }
        self.frames[self.head] = frame;
        self.sensors[self.head] = sensor;
        self.lags[self.head] = lag;
        self.felt[self.head] = felt;
        self.head = (self.head + 1) % self.capacity;
    }

    /// Time of the newest frame.
    pub fn newest_t_s(&self) -> Option<f64> {
        (self.len > 0).then(|| self.frames[self.index(self.len - 1)].t_s)
    }

    /// Time of the oldest frame.
    pub fn oldest_t_s(&self) -> Option<f64> {
        (self.len > 0).then(|| self.frames[self.index(0)].t_s)
    }

    fn index(&self, i: usize) -> usize {
        (self.head + i) % self.capacity
    }

    /// Position (from the oldest) of the first entry at or after `t_s`.
    fn first_at_or_after(&self, t_s: f64) -> usize {
        // Times increase along the buffer: binary search.
        let (mut lo, mut hi) = (0, self.len);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.frames[self.index(mid)].t_s < t_s {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The entries with `t_s >= from_s`, oldest first, as up to two slices of frames and the
    /// matching slices of believed sensor positions.
    pub fn since(&self, from_s: f64) -> Window<'_> {
        self.between(from_s, f64::INFINITY)
    }

    /// The entries with `from_s <= t_s < to_s`, oldest first (a beat inside a longer window).
    pub fn between(&self, from_s: f64, to_s: f64) -> Window<'_> {
        let start = self.first_at_or_after(from_s);
        let count = self.first_at_or_after(to_s).saturating_sub(start);
        let first = self.index(start);
        if count == 0 {
            return Window {
                frames: [&[], &[]],
                sensors: [&[], &[]],
                lags: [&[], &[]],
                felt: [&[], &[]],
            };
        }
        let end = first + count;
        if end <= self.frames.len() {
            Window {
                frames: [&self.frames[first..end], &[]],
                sensors: [&self.sensors[first..end], &[]],
                lags: [&self.lags[first..end], &[]],
                felt: [&self.felt[first..end], &[]],
            }
        } else {
            let wrap = end - self.frames.len();
            Window {
                frames: [&self.frames[first..], &self.frames[..wrap]],
                sensors: [&self.sensors[first..], &self.sensors[..wrap]],
                lags: [&self.lags[first..], &self.lags[..wrap]],
                felt: [&self.felt[first..], &self.felt[..wrap]],
            }
        }
    }
}

/// A run of consecutive history entries.
#[derive(Debug, Clone, Copy)]
pub struct Window<'a> {
    frames: [&'a [TactileFrame]; 2],
    sensors: [&'a [SurfacePoint]; 2],
    lags: [&'a [[f64; 2]]; 2],
    felt: [&'a [[f64; 2]]; 2],
}

impl<'a> Window<'a> {
    pub fn len(&self) -> usize {
        self.frames[0].len() + self.frames[1].len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The frames, oldest first.
    pub fn frames(&self) -> impl Iterator<Item = &'a TactileFrame> + Clone + 'a {
        self.frames[0].iter().chain(self.frames[1].iter())
    }

    /// The believed sensor positions, oldest first.
    pub fn sensors(&self) -> impl Iterator<Item = &'a SurfacePoint> + Clone + 'a {
        self.sensors[0].iter().chain(self.sensors[1].iter())
    }

    /// Mean believed sensor position (finite ones only).
    pub fn mean_sensor(&self) -> Option<SurfacePoint> {
        let (mut x, mut z, mut n) = (0.0, 0.0, 0usize);
        for s in self.sensors().filter(|s| s.is_finite()) {
            x += s.x_m;
            z += s.z_m;
            n += 1;
        }
        (n > 0).then(|| SurfacePoint::new(x / n as f64, z / n as f64))
    }

    /// Mean lag direction over the window.
    pub fn mean_lag(&self) -> [f64; 2] {
        let (mut x, mut z, mut n) = (0.0, 0.0, 0usize);
        for l in self.lags[0].iter().chain(self.lags[1].iter()) {
            x += l[0];
            z += l[1];
            n += 1;
        }
        if n == 0 {
            [0.0, 0.0]
        } else {
            [x / n as f64, z / n as f64]
        }
    }

    /// Mean of where the arm's load put the sensor less where it was believed, over the
    /// window; `None` unless every frame of it has that reading. Over whole beats the
    /// pulse's own push on the sensor, which swings the load, averages out.
    pub fn mean_felt_offset(&self) -> Option<[f64; 2]> {
        let (mut x, mut z, mut n) = (0.0, 0.0, 0usize);
        for d in self.felt[0].iter().chain(self.felt[1].iter()) {
            if !(d[0].is_finite() && d[1].is_finite()) {
                return None;
            }
            x += d[0];
            z += d[1];
            n += 1;
        }
        (n > 0).then(|| [x / n as f64, z / n as f64])
    }

    pub fn first_t_s(&self) -> Option<f64> {
        self.frames().next().map(|f| f.t_s)
    }

    pub fn last_t_s(&self) -> Option<f64> {
        self.frames().last().map(|f| f.t_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(i: u64) -> TactileFrame {
        TactileFrame {
            t_s: i as f64 * 0.01,
            seq: i,
            force_n: [i as f64; crate::types::ELEMENTS],
        }
    }

    #[test]
    fn windows_wrap_around_and_keep_the_newest() {
        let mut h = History::new(5);
        assert!(h.since(0.0).is_empty());
        for i in 0..8 {
            let loaded = (i >= 5).then(|| SurfacePoint::new(i as f64 + 0.5, -1.0));
            h.push(
                frame(i),
                SurfacePoint::new(i as f64, 0.0),
                [0.0, i as f64],
                loaded,
            );
        }
        assert_eq!(h.len(), 5);
        assert_eq!(h.oldest_t_s(), Some(0.03));
        assert_eq!(h.newest_t_s(), Some(0.07));
        let w = h.since(0.045);
        let seqs: Vec<u64> = w.frames().map(|f| f.seq).collect();
        assert_eq!(seqs, vec![5, 6, 7]);
        let xs: Vec<f64> = w.sensors().map(|s| s.x_m).collect();
        assert_eq!(xs, vec![5.0, 6.0, 7.0]);
        assert_eq!(w.mean_sensor(), Some(SurfacePoint::new(6.0, 0.0)));
        assert_eq!(w.mean_lag(), [0.0, 6.0]);
        assert_eq!(w.mean_felt_offset(), Some([0.5, -1.0]));
        // One frame without the reading and the window has none.
        assert_eq!(h.since(0.035).mean_felt_offset(), None);
        assert_eq!(h.since(0.0).len(), 5);
        assert!(h.since(1.0).is_empty());
        // A span inside: its end excluded, across the ring's wrap, and empty when reversed.
        let seqs: Vec<u64> = h.between(0.035, 0.065).frames().map(|f| f.seq).collect();
        assert_eq!(seqs, vec![4, 5, 6]);
        let xs: Vec<f64> = h.between(0.0, 0.045).sensors().map(|s| s.x_m).collect();
        assert_eq!(xs, vec![3.0, 4.0]);
        assert!(h.between(0.06, 0.04).is_empty());
        h.clear();
        assert!(h.is_empty() && h.newest_t_s().is_none());
    }
}
