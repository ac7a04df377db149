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
