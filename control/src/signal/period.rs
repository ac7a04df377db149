//! The running estimate of the pulse period.
//!
//! The seed: the first acquisition gives the period; each later acquisition's result is
//! "averaged with the current estimate of pulse timing to continually update the
//! estimate". We read that as the mean of the current estimate and the new period, which
//! weighs recent acquisitions most (an exponential average with factor 1/2) and so follows
//! a slowly changing heart rate.

/// The current period estimate, if any.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunningPeriod {
    estimate_s: Option<f64>,
}

impl RunningPeriod {
    pub const fn new() -> Self {
        Self { estimate_s: None }
    }

    pub fn estimate_s(&self) -> Option<f64> {
        self.estimate_s
    }

    /// The estimate that [`RunningPeriod::update`] with `period_s` would produce.
    pub fn with(&self, period_s: f64) -> f64 {
        match self.estimate_s {
            None => period_s,
            Some(current) => 0.5 * (current + period_s),
        }
    }

    /// Fold in a newly measured period (ignored unless finite and positive); returns the
    /// new estimate.
    pub fn update(&mut self, period_s: f64) -> Option<f64> {
        if period_s.is_finite() && period_s > 0.0 {
            self.estimate_s = Some(self.with(period_s));
        }
        self.estimate_s
    }

    pub fn reset(&mut self) {
        self.estimate_s = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_sets_then_averages() {
        let mut p = RunningPeriod::new();
        assert_eq!(p.estimate_s(), None);
        assert_eq!(p.update(1.0), Some(1.0));
        assert_eq!(p.update(0.8), Some(0.9));
        assert_eq!(p.update(f64::NAN), Some(0.9));
        assert_eq!(p.update(-1.0), Some(0.9));
        assert_eq!(p.update(0.9), Some(0.9));
    }
}
