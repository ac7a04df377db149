//! Turns decoded force messages into [`TactileFrame`]s: sequence gaps and duplicates,
//! channel-count and range checks, and the mapping of the device clock onto the consumer's.

use control::types::{ELEMENTS, TactileFrame};

use super::wire::{ELEMENT_FAULT, Forces, NEWTONS_PER_COUNT};

/// How far the clock map's offset may creep up per second of device time (s/s): covers a
/// device crystal slower than the host by up to 200 ppm.
const CLOCK_RELAX_S_PER_S: f64 = 2.0e-4;

/// Consecutive frames from "before" the current sequence after which the device is taken
/// to have restarted its counter (rather than replaying old frames).
const RESYNC_AFTER_BEHIND: u32 = 3;

/// Smallest step between consecutive stamps, s.
pub const MIN_STAMP_STEP_S: f64 = 1e-6;

/// Why a well-formed force message did not become a frame.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum Rejection {
    #[error("frame {seq} repeats the previous sequence number")]
    Duplicate { seq: u32 },
    #[error("frame {seq} is older than the newest frame {newest}")]
    Reordered { seq: u32, newest: u32 },
    #[error("frame carries {got} channels, the array has {ELEMENTS}")]
    WrongChannelCount { got: usize },
    #[error("element {element} reports a fault")]
    ElementFault { element: usize },
    #[error("element {element} reads {force_n} N, beyond the ±{limit_n} N accepted")]
    OutOfRange {
        element: usize,
        force_n: f64,
        limit_n: f64,
    },
}

/// The verdict on one message: the frame or why not, and what the sequence number said
/// (a rejected message still reveals frames lost before it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checked {
    pub frame: Result<TactileFrame, Rejection>,
    /// Frames that went missing just before this one.
    pub missing: u64,
    /// The sequence restarted (device reset): counted, not a gap.
    pub resynced: bool,
}

impl Checked {
    /// The frame; panics in tests only.
    #[cfg(test)]
    fn ok(self) -> TactileFrame {
        match self.frame {
            Ok(f) => f,
            Err(e) => panic!("rejected: {e}"),
        }
    }
}

/// Maps the device's wrapping µs clock onto the consumer's clock.
///
/// The transport adds a latency that is never negative and often bunches frames (a USB
/// serial adapter's latency timer). The smallest `arrival - device_time` seen is the best
/// estimate of the offset; it is allowed to creep up slowly so that clock drift cannot pin
/// it to an old minimum. A stamp is never later than the frame's arrival, and always later
/// than the previous stamp (consumers assume strictly increasing times): frames that arrive
/// together before the transport's latency is known get stamps [`MIN_STAMP_STEP_S`] apart,
/// which may put them that little past their arrival.
#[derive(Debug, Clone, Copy)]
pub struct DeviceClockMap {
    last_us: Option<u32>,
    device_s: f64,
    offset_s: f64,
    last_stamp_s: f64,
}

impl Default for DeviceClockMap {
    fn default() -> Self {
        Self {
            last_us: None,
            device_s: 0.0,
            offset_s: 0.0,
            last_stamp_s: f64::NEG_INFINITY,
        }
    }
}

impl DeviceClockMap {
    /// Forget the device clock (a new connection or a device reset); stamps still never go
    /// back.
    pub fn reset(&mut self) {
        *self = Self {
            last_stamp_s: self.last_stamp_s,
            ..Self::default()
        };
    }

    /// The consumer-clock time at which the device took a sample stamped `device_us`,
    /// given that it arrived at `arrival_s`.
    pub fn stamp(&mut self, device_us: u32, arrival_s: f64) -> f64 {
        match self.last_us {
            Some(prev) if device_us.wrapping_sub(prev) <= u32::MAX / 2 => {
                let dt_s = f64::from(device_us.wrapping_sub(prev)) * 1e-6;
                self.device_s += dt_s;
                self.offset_s =
                    (self.offset_s + CLOCK_RELAX_S_PER_S * dt_s).min(arrival_s - self.device_s);
            }
            // First sample, or the device clock went backwards (a reset): start over.
            _ => {
                self.device_s = 0.0;
                self.offset_s = arrival_s;
            }
        }
        self.last_us = Some(device_us);
        let stamp = (self.device_s + self.offset_s)
            .min(arrival_s)
            .max(self.last_stamp_s + MIN_STAMP_STEP_S);
        self.last_stamp_s = stamp;
        stamp
    }
}

/// Sequence and content checks for one connection's stream.
#[derive(Debug, Clone)]
pub struct StreamCheck {
    max_force_n: f64,
    newest: Option<u32>,
    seq: u64,
    behind_in_row: u32,
    restart_expected: bool,
    clock: DeviceClockMap,
}

impl StreamCheck {
    /// `max_force_n`: largest magnitude accepted on any element.
    pub fn new(max_force_n: f64) -> Self {
        Self {
            max_force_n,
            newest: None,
            seq: 0,
            behind_in_row: 0,
            restart_expected: false,
            clock: DeviceClockMap::default(),
        }
    }

    /// The device announced itself: if the next frame's sequence number is behind, the
    /// device restarted its counter; follow it at once instead of waiting for proof.
    pub fn expect_restart(&mut self) {
        self.restart_expected = true;
    }

    /// Start over (new connection or the device announced itself again). The unwrapped
    /// sequence keeps counting up so that consumers never see it go backwards.
    pub fn restart(&mut self) {
        if self.newest.is_some() {
            self.seq += 1;
        }
        self.newest = None;
        self.behind_in_row = 0;
        self.restart_expected = false;
        self.clock.reset();
    }

    pub fn accept(&mut self, f: &Forces, arrival_s: f64) -> Checked {
        let mut missing = 0;
        let mut resynced = false;
        if let Some(newest) = self.newest {
            let ahead = f.seq.wrapping_sub(newest);
            let reject = |r| Checked {
                frame: Err(r),
                missing: 0,
                resynced: false,
            };
            if ahead == 0 {
                return reject(Rejection::Duplicate { seq: f.seq });
            } else if ahead <= u32::MAX / 2 {
                missing = u64::from(ahead - 1);
                self.seq += u64::from(ahead);
                self.behind_in_row = 0;
            } else {
                self.behind_in_row += 1;
                if self.behind_in_row < RESYNC_AFTER_BEHIND && !self.restart_expected {
                    return reject(Rejection::Reordered { seq: f.seq, newest });
                }
                self.restart();
                resynced = true;
            }
        }
        self.newest = Some(f.seq);
        self.restart_expected = false;
        let t_s = self.clock.stamp(f.device_time_us, arrival_s);
        Checked {
            frame: self.content(f, t_s),
            missing,
            resynced,
        }
    }

    fn content(&self, f: &Forces, t_s: f64) -> Result<TactileFrame, Rejection> {
        let counts = f.counts();
        if counts.len() != ELEMENTS {
            return Err(Rejection::WrongChannelCount { got: counts.len() });
        }
        let mut force_n = [0.0; ELEMENTS];
        for (element, (&c, out)) in counts.iter().zip(force_n.iter_mut()).enumerate() {
            if c == ELEMENT_FAULT {
                return Err(Rejection::ElementFault { element });
            }
            let n = f64::from(c) * NEWTONS_PER_COUNT;
            if n.abs() > self.max_force_n {
                return Err(Rejection::OutOfRange {
                    element,
                    force_n: n,
                    limit_n: self.max_force_n,
                });
            }
            *out = n;
        }
        Ok(TactileFrame {
            t_s,
            seq: self.seq,
            force_n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(seq: u32, t_us: u32, c: i16) -> Forces {
        Forces::new(seq, t_us, &[c; ELEMENTS]).expect("fits")
    }

    #[test]
    fn scaling_is_a_tenth_of_a_millinewton_per_count() {
        let mut s = StreamCheck::new(3.0);
        let mut counts = [0i16; ELEMENTS];
        counts[0] = 600; // 0.06 N, the seed's largest pulse
        counts[9] = -1234;
        let f = Forces::new(1, 0, &counts).expect("fits");
        let a = s.accept(&f, 5.0).ok();
        assert!((a.force_n[0] - 0.06).abs() < 1e-12);
        assert!((a.force_n[9] + 0.1234).abs() < 1e-12);
        assert_eq!(a.t_s, 5.0);
    }

    #[test]
    fn gaps_duplicates_and_wraparound() {
        let mut s = StreamCheck::new(3.0);
        let base = u32::MAX - 1;
        let a = s.accept(&msg(base, 0, 1), 0.0);
        assert_eq!(a.missing, 0);
        assert_eq!(
            s.accept(&msg(base, 0, 1), 0.0).frame,
            Err(Rejection::Duplicate { seq: base })
        );
        // Wraps from MAX-1 to 2: MAX and 0 and 1 are missing.
        let b = s.accept(&msg(2, 40_000, 1), 0.04);
        assert_eq!(b.missing, 3);
        assert_eq!(b.ok().seq, a.ok().seq + 4);
        assert_eq!(
            s.accept(&msg(1, 30_000, 1), 0.05).frame,
            Err(Rejection::Reordered { seq: 1, newest: 2 })
        );
    }

    #[test]
    fn a_restarted_counter_resyncs_after_three_frames() {
        let mut s = StreamCheck::new(3.0);
        let first = s.accept(&msg(5000, 0, 1), 0.0).ok().seq;
        assert!(s.accept(&msg(0, 0, 1), 0.01).frame.is_err());
        assert!(s.accept(&msg(1, 10_000, 1), 0.02).frame.is_err());
        let r = s.accept(&msg(2, 20_000, 1), 0.03);
        assert!(r.resynced);
        let r = r.ok();
        assert_eq!(r.seq, first + 1);
        let next = s.accept(&msg(3, 30_000, 1), 0.04);
        assert_eq!(next.missing, 0);
        assert_eq!(next.ok().seq, r.seq + 1);
    }

    #[test]
    fn an_announced_restart_is_followed_at_once() {
        let mut s = StreamCheck::new(3.0);
        let a = s.accept(&msg(700, 0, 1), 0.0).ok().seq;
        s.expect_restart();
        let b = s.accept(&msg(0, 0, 1), 0.5);
        assert!(b.resynced);
        assert_eq!(b.ok().seq, a + 1);
        // Without an announcement a step back is rejected.
        assert!(s.accept(&msg(0, 0, 1), 0.6).frame.is_err());
    }

    #[test]
    fn bad_content_is_rejected_but_keeps_its_sequence_slot() {
        let mut s = StreamCheck::new(1.0);
        s.accept(&msg(1, 0, 0), 0.0).ok();
        // Frame 2 is lost; frame 3 has nine channels: rejected, but it reveals the loss.
        let nine = Forces::new(3, 10_000, &[0; 9]).expect("fits");
        let c = s.accept(&nine, 0.01);
        assert_eq!(c.frame, Err(Rejection::WrongChannelCount { got: 9 }));
        assert_eq!(c.missing, 1);
        let mut counts = [0i16; ELEMENTS];
        counts[4] = ELEMENT_FAULT;
        let fault = Forces::new(4, 20_000, &counts).expect("fits");
        assert_eq!(
            s.accept(&fault, 0.02).frame,
            Err(Rejection::ElementFault { element: 4 })
        );
        counts[4] = 0;
        counts[7] = 20_000; // 2 N > 1 N
        let big = Forces::new(5, 30_000, &counts).expect("fits");
        assert!(matches!(
            s.accept(&big, 0.03).frame,
            Err(Rejection::OutOfRange { element: 7, .. })
        ));
        // The next good frame follows with no gap: the rejected ones were received.
        let ok = s.accept(&msg(6, 40_000, 0), 0.04);
        assert_eq!(ok.missing, 0);
        assert!(ok.frame.is_ok());
    }

    #[test]
    fn bunched_arrivals_get_the_device_spacing() {
        // 100 Hz frames delivered four at a time every 40 ms with 3 ms to 9 ms of latency.
        let mut m = DeviceClockMap::default();
        let mut stamps = Vec::new();
        for k in 0u32..40 {
            let device_us = 1_000_000 + k * 10_000;
            let batch_end = f64::from(k / 4 + 1) * 0.040;
            let arrival = 100.0 + batch_end + 0.003 + 0.0001 * f64::from(k % 4);
            let t = m.stamp(device_us, arrival);
            assert!(t <= arrival);
            stamps.push(t);
        }
        // After the first batch has shown the smallest latency, stamps are the device's
        // 10 ms apart, give or take the 200 ppm drift allowance over one batch.
        for w in stamps[4..].windows(2) {
            let spacing = w[1] - w[0];
            assert!((spacing - 0.010).abs() <= 1e-5, "spacing {spacing}");
        }
    }

    #[test]
    fn a_new_smallest_latency_never_moves_stamps_back() {
        let mut m = DeviceClockMap::default();
        let a = m.stamp(0, 10.020); // 20 ms late
        let b = m.stamp(10_000, 10.011); // 1 ms late: the offset falls by 19 ms
        assert_eq!(a, 10.020);
        assert_eq!(
            b,
            10.020 + MIN_STAMP_STEP_S,
            "just after the previous stamp, not back"
        );
        let c = m.stamp(20_000, 10.021);
        assert!((c - 10.021).abs() < 1e-9);
    }

    #[test]
    fn device_clock_wrap_and_reset() {
        let mut m = DeviceClockMap::default();
        let t0 = m.stamp(u32::MAX - 4_999, 10.0);
        let t1 = m.stamp(5_000, 10.010); // wrapped: 10 ms later
        assert!((t1 - t0 - 0.010).abs() < 1e-9);
        // The device clock jumps back (the device reset): stamps follow arrival again.
        let t2 = m.stamp(0, 10.5);
        assert_eq!(t2, 10.5);
    }

    #[test]
    fn a_slow_device_clock_is_followed() {
        // Device clock 100 ppm slow, fixed 2 ms latency: the stamp error stays bounded.
        let mut m = DeviceClockMap::default();
        for k in 0u32..100_000 {
            let true_t = f64::from(k) * 0.01;
            let device_us = (true_t * (1.0 - 100e-6) * 1e6) as u32;
            let t = m.stamp(device_us, true_t + 0.002);
            assert!((t - true_t).abs() < 0.0025, "k {k}: error {}", t - true_t);
        }
    }
}
