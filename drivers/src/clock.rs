//! The consumer's monotonic clock, supplied by whoever owns the control loop.
//!
//! Drivers stamp data with it so that frames, joint states and the loop's own deadlines are
//! on one time base. The daemon passes its clock (wall-monotonic on the rig, simulated in
//! the sim); tests may pass a scaled or fake one.

use std::sync::Arc;
use std::time::Instant;

/// Seconds on a monotonic time base. Must never go backwards.
pub trait Clock: Send + Sync {
    fn now_s(&self) -> f64;
}

impl std::fmt::Debug for dyn Clock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Clock(now {} s)", self.now_s())
    }
}

impl<F: Fn() -> f64 + Send + Sync> Clock for F {
    fn now_s(&self) -> f64 {
        self()
    }
}

impl<C: Clock + ?Sized> Clock for Arc<C> {
    fn now_s(&self) -> f64 {
        (**self).now_s()
    }
}

/// `std::time::Instant` seconds since construction, optionally sped up by a factor (tests
/// that pair a faster-than-real-time emulator with the driver).
#[derive(Debug, Clone, Copy)]
pub struct MonotonicClock {
    origin: Instant,
    scale: f64,
}

impl MonotonicClock {
    pub fn new() -> Self {
        Self::scaled(1.0)
    }

    pub fn scaled(scale: f64) -> Self {
        Self {
            origin: Instant::now(),
            scale,
        }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for MonotonicClock {
    fn now_s(&self) -> f64 {
        self.origin.elapsed().as_secs_f64() * self.scale
    }
}

/// A clock moved by hand (tests, log replay).
#[derive(Debug, Clone, Default)]
pub struct ManualClock(Arc<std::sync::atomic::AtomicU64>);

impl ManualClock {
    pub fn new(t_s: f64) -> Self {
        let c = Self::default();
        c.set(t_s);
        c
    }

    pub fn set(&self, t_s: f64) {
        self.0
            .store(t_s.to_bits(), std::sync::atomic::Ordering::Relaxed);
    }

    pub fn advance(&self, dt_s: f64) {
        self.set(self.now_s() + dt_s);
    }
}

impl Clock for ManualClock {
    fn now_s(&self) -> f64 {
        f64::from_bits(self.0.load(std::sync::atomic::Ordering::Relaxed))
    }
}
