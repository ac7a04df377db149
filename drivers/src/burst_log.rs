//! Logging a run of similar problems once: the first occurrence when it starts, a count when
//! it ends. A stream of bad frames must not flood the journal.

/// One kind of recurring problem on one link.
#[derive(Debug, Clone)]
pub struct BurstLog {
    what: &'static str,
    quiet_s: f64,
    active: bool,
    count: u64,
    last_s: f64,
}

impl BurstLog {
    /// `what` names the problem in the log; a burst ends after `quiet_s` without it.
    pub fn new(what: &'static str, quiet_s: f64) -> Self {
        Self {
            what,
            quiet_s,
            active: false,
            count: 0,
            last_s: f64::NEG_INFINITY,
        }
    }

    /// Record one occurrence at `now_s`; logs `detail` only if this starts a burst.
    /// Returns true when it logged.
    pub fn event(&mut self, now_s: f64, detail: impl FnOnce() -> String) -> bool {
        self.end_if_quiet(now_s);
        self.count += 1;
        self.last_s = now_s;
        if self.active {
            return false;
        }
        self.active = true;
        tracing::warn!(
            "{}: {} (further ones are counted, not logged)",
            self.what,
            detail()
        );
        true
    }

    /// Close the burst if it has been quiet long enough; logs how many there were.
    pub fn end_if_quiet(&mut self, now_s: f64) {
        // NaN times end a burst rather than keep it open forever.
        let quiet =
            (now_s - self.last_s).partial_cmp(&self.quiet_s) != Some(std::cmp::Ordering::Less);
        if self.active && quiet {
            tracing::info!("{}: burst over, {} in all", self.what, self.count);
            self.active = false;
            self.count = 0;
        }
    }

    pub fn in_burst(&self) -> bool {
        self.active
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logs_once_per_burst() {
        let mut b = BurstLog::new("crc errors", 1.0);
        assert!(b.event(0.0, || "first".into()));
        for k in 1..100 {
            assert!(!b.event(f64::from(k) * 0.01, || "again".into()));
        }
        b.end_if_quiet(1.5);
        assert!(b.in_burst(), "0.51 s since the last is not yet quiet");
        b.end_if_quiet(2.0);
        assert!(!b.in_burst());
        assert!(b.event(2.1, || "a new burst".into()));
    }
}
