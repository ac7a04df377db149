//! Loop timing statistics without allocation: a fixed histogram of cycle periods in
//! microseconds, percentiles on demand, and overrun counts.

use serde::Serialize;

/// Periods are binned per microsecond up to this bound; longer ones land in the last bin
/// (their exact maximum is kept separately).
const BINS: usize = 20_000;

/// Percentiles of the measured period, microseconds of wall time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct PeriodSummary {
    pub cycles: u64,
    pub target_us: f64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    pub max_us: f64,
    /// Cycles whose work ended after the next deadline.
    pub overruns: u64,
    /// Deadlines skipped altogether because a cycle ran over by more than a period (in
    /// batched pacing: control cycles of simulated time that could not be run in time).
    pub skipped: u64,
    /// Batched pacing (a simulation faster than real time): the period is that of the
    /// batches, not of single cycles.
    pub batched: bool,
    /// Daemon-clock seconds run per wall second since the loop started.
    pub achieved_time_scale: f64,
}

#[derive(Debug, Clone)]
pub struct PeriodStats {
    bins: Box<[u32; BINS]>,
    cycles: u64,
    max_ns: i64,
    overruns: u64,
    skipped: u64,
    target_ns: i64,
}

impl PeriodStats {
    /// Allocates the histogram once, here, before the loop starts.
    pub fn new(target_ns: i64) -> Self {
        Self {
            bins: Box::new([0; BINS]),
            cycles: 0,
            max_ns: 0,
            overruns: 0,
            skipped: 0,
            target_ns,
        }
    }

    pub fn record_period(&mut self, period_ns: i64) {
        let us = (period_ns.max(0) / 1000) as usize;
        let bin = us.min(BINS - 1);
        self.bins[bin] = self.bins[bin].saturating_add(1);
        self.cycles += 1;
        self.max_ns = self.max_ns.max(period_ns);
    }

    pub fn record_overrun(&mut self, skipped_deadlines: u64) {
        self.overruns += 1;
        self.skipped += skipped_deadlines;
    }

    pub fn overruns(&self) -> u64 {
        self.overruns
    }

    fn percentile_us(&self, q: f64) -> f64 {
        if self.cycles == 0 {
            return 0.0;
        }
        let rank = ((self.cycles as f64) * q).ceil().max(1.0) as u64;
        let mut seen = 0u64;
        for (us, n) in self.bins.iter().enumerate() {
            seen += u64::from(*n);
            if seen >= rank {
                return us as f64;
            }
        }
        (BINS - 1) as f64
    }

    /// Percentiles over everything recorded (a scan of the histogram: call it rarely).
    pub fn summary(&self) -> PeriodSummary {
        PeriodSummary {
            cycles: self.cycles,
            target_us: self.target_ns as f64 / 1000.0,
            p50_us: self.percentile_us(0.5),
            p99_us: self.percentile_us(0.99),
            p999_us: self.percentile_us(0.999),
            max_us: self.max_ns as f64 / 1000.0,
            overruns: self.overruns,
            skipped: self.skipped,
            batched: false,
            achieved_time_scale: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_of_a_known_distribution() {
        let mut s = PeriodStats::new(1_000_000);
        // 990 periods of 1000 us, 9 of 1500 us, one of 30 ms (beyond the histogram).
        for _ in 0..990 {
            s.record_period(1_000_400);
        }
        for _ in 0..9 {
            s.record_period(1_500_000);
        }
        s.record_period(30_000_000);
        let m = s.summary();
        assert_eq!(m.cycles, 1000);
        assert_eq!(m.p50_us, 1000.0);
        assert_eq!(m.p99_us, 1000.0);
        assert_eq!(m.p999_us, 1500.0);
        assert_eq!(m.max_us, 30_000.0);
    }

    #[test]
    fn empty_stats_are_zero_not_nan() {
        let m = PeriodStats::new(1_000_000).summary();
        assert_eq!(m.p50_us, 0.0);
        assert_eq!(m.cycles, 0);
    }
}
