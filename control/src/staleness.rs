//! Staleness of a data stream judged against the caller's clock.

/// Tracks the newest sample time of a stream and says when it is too old.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StalenessMonitor {
    max_age_s: f64,
    newest_s: Option<f64>,
}

/// What the monitor concludes at a given instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Freshness {
    /// No sample has been seen yet.
    NeverSeen,
    /// The newest sample is within the allowed age.
    Fresh { age_s: f64 },
    /// The newest sample is older than allowed.
    Stale { age_s: f64 },
}

impl StalenessMonitor {
    /// `max_age_s` must be positive and finite; anything else is treated as "always stale".
    pub fn new(max_age_s: f64) -> Self {
        Self {
            max_age_s,
            newest_s: None,
        }
    }

    /// Record a sample stamped `t_s`. Older or non-finite stamps do not move the clock back.
    pub fn observe(&mut self, t_s: f64) {
        if !t_s.is_finite() {
            return;
        }
        self.newest_s = Some(match self.newest_s {
            Some(prev) if prev >= t_s => prev,
            _ => t_s,
        });
    }

    /// Judge freshness at `now_s`.
    pub fn check(&self, now_s: f64) -> Freshness {
        let Some(newest) = self.newest_s else {
            return Freshness::NeverSeen;
        };
        let age_s = now_s - newest;
        let limit_ok = self.max_age_s.is_finite() && self.max_age_s > 0.0;
        if limit_ok && age_s.is_finite() && age_s <= self.max_age_s {
            Freshness::Fresh { age_s }
        } else {
            Freshness::Stale { age_s }
        }
    }

    pub fn is_fresh(&self, now_s: f64) -> bool {
        matches!(self.check(now_s), Freshness::Fresh { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresh_then_stale_and_never_backwards() {
        let mut m = StalenessMonitor::new(0.05);
        assert_eq!(m.check(1.0), Freshness::NeverSeen);
        m.observe(1.0);
        assert!(m.is_fresh(1.04));
        assert!(!m.is_fresh(1.06));
        m.observe(0.5); // an out-of-order stamp does not refresh or age the stream
        assert!(m.is_fresh(1.04));
        m.observe(f64::NAN);
        assert!(m.is_fresh(1.04));
    }

    #[test]
    fn invalid_limit_is_always_stale() {
        let mut m = StalenessMonitor::new(f64::NAN);
        m.observe(1.0);
        assert!(!m.is_fresh(1.0));
    }
}
