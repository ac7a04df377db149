//! The rig's clock: CLOCK_MONOTONIC seconds since the daemon started.

use crate::rt::os::MonoNs;

#[derive(Debug, Clone, Copy)]
pub struct MonotonicClock {
    epoch: MonoNs,
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl MonotonicClock {
    pub fn new() -> Self {
        Self {
            epoch: MonoNs::now(),
        }
    }

    pub fn now_s(&self) -> f64 {
        MonoNs::now().ns_since(self.epoch) as f64 * 1e-9
    }
}
