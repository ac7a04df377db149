//! The loop's own thread: SCHED_FIFO and locked memory where allowed, sleeping to absolute
//! deadlines on CLOCK_MONOTONIC, counting overruns without catch-up bursts, and reporting a
//! timing summary at a bounded rate.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

use crate::rt::control_loop::ControlLoop;
use crate::rt::fault::{Fault, FaultKind};
use crate::rt::link::{ControlEvent, LoopMode};
use crate::rt::os::{self, MonoNs};
use crate::rt::period_stats::{PeriodStats, PeriodSummary};

/// How the loop's thread is paced and what it may ask of the OS.
#[derive(Debug, Clone)]
pub struct Pacing {
    /// Control rate on the daemon's clock, Hz.
    pub rate_hz: f64,
    /// Daemon-clock seconds per wall second (the simulator's time_scale; 1 on the rig).
    pub time_scale: f64,
    pub fifo_priority: Option<u8>,
    pub lock_memory: bool,
    /// Wall seconds between timing reports.
    pub report_every_s: f64,
    /// Consecutive overruns that fault a loop bound to the wall clock (`None`: only count).
    pub max_consecutive_overruns: Option<u32>,
}

impl Pacing {
    /// The wall-clock period between deadlines, ns (at least 1 µs).
    pub fn period_ns(&self) -> i64 {
        let ns = 1.0e9 / (self.rate_hz * self.time_scale);
        if ns.is_finite() {
            (ns.round() as i64).max(1_000)
        } else {
            1_000
        }
    }
}

/// A running loop thread.
#[derive(Debug)]
pub struct LoopThread {
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl LoopThread {
    pub fn spawn(mut control: ControlLoop, pacing: Pacing) -> std::io::Result<LoopThread> {
        let stop = Arc::new(AtomicBool::new(false));
        let stop_in = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name("pulsetrack-rt".into())
            .spawn(move || run(&mut control, &pacing, &stop_in))?;
        Ok(LoopThread {
            stop,
            handle: Some(handle),
        })
    }

    /// Ask the loop to power off and end, and wait for it.
    pub fn stop(mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(h) = self.handle.take()
            && h.join().is_err()
        {
            tracing::error!("the control thread panicked");
        }
    }
}

impl Drop for LoopThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// Ask for real-time scheduling; warn once for each refusal and carry on.
fn make_real_time(p: &Pacing) {
    if p.lock_memory
        && let Err(e) = os::lock_all_memory()
    {
        tracing::warn!(
            "mlockall refused ({e}); the loop may page-fault (needs CAP_IPC_LOCK or LimitMEMLOCK)"
        );
    }
    // A loop paced faster than every 200 µs runs a simulation faster than real time in
    // batches: it has no deadline worth a real-time priority, and at SCHED_FIFO it would
    // starve the rest of the machine.
    if p.fifo_priority.is_some() && p.period_ns() < BATCH_BELOW_NS {
        tracing::info!(
            "loop period {} us (time scale {}): not asking for SCHED_FIFO",
            p.period_ns() / 1000,
            p.time_scale
        );
    } else if let Some(prio) = p.fifo_priority
        && let Err(e) = os::set_fifo_priority(prio)
    {
        tracing::warn!(
            "SCHED_FIFO priority {prio} refused ({e}); running the 1 kHz loop at normal priority \
             (needs CAP_SYS_NICE or LimitRTPRIO)"
        );
    }
    os::prefault_stack(256 * 1024);
}

/// Pacing below this period would sleep for tens of microseconds a cycle (a simulation far
/// faster than real time): the loop then runs the due cycles in batches every millisecond.
const BATCH_BELOW_NS: i64 = 200_000;
const BATCH_TICK_NS: i64 = 1_000_000;

fn run(control: &mut ControlLoop, p: &Pacing, stop: &AtomicBool) {
    make_real_time(p);
    let start = MonoNs::now();
    let start_clock = control.now_s();
    let summary = if p.period_ns() < BATCH_BELOW_NS {
        run_batched(control, p, stop)
    } else {
        run_paced(control, p, stop)
    };
    control.shut_down();
    let wall_s = MonoNs::now().ns_since(start) as f64 * 1e-9;
    let mut summary = summary;
    summary.achieved_time_scale = (control.now_s() - start_clock) / wall_s.max(1e-9);
    let _ = control_events(control, summary);
}

/// One cycle per deadline, sleeping to each absolute deadline.
fn run_paced(control: &mut ControlLoop, p: &Pacing, stop: &AtomicBool) -> PeriodSummary {
    let period = p.period_ns();
    let mut stats = PeriodStats::new(period);
    let report_every_ns = (p.report_every_s * 1e9) as i64;
    let mut next_report = MonoNs::now().plus_ns(report_every_ns);
    let mut consecutive = 0u32;
    let mut last_wake = MonoNs::now();
    let mut next = last_wake.plus_ns(period);
    let mut first = true;

    while !stop.load(Ordering::Acquire) {
        os::sleep_until(next);
        let wake = MonoNs::now();
        if !first {
            stats.record_period(wake.ns_since(last_wake));
        }
        first = false;
        last_wake = wake;

        control.cycle();

        next = next.plus_ns(period);
        let end = MonoNs::now();
        if end > next {
            // Skip the deadlines already missed instead of bursting to catch up.
            let behind = end.ns_since(next);
            let skipped = (behind / period) as u64;
            next = next.plus_ns((skipped as i64 + 1) * period);
            stats.record_overrun(skipped);
            control.set_overruns(stats.overruns());
            consecutive += 1;
            if let Some(max) = p.max_consecutive_overruns
                && consecutive >= max
                && control.mode() == LoopMode::Enabled
            {
                let now = control.now_s();
                control.latch_external(
                    Fault::new(FaultKind::Deadline, now)
                        .with_values(f64::from(consecutive), f64::from(max)),
                );
            }
        } else {
            consecutive = 0;
        }

        if end >= next_report {
            next_report = end.plus_ns(report_every_ns);
            // Allocation-free: PeriodSummary is Copy; the scan takes a few µs every few s.
            let _ = control_events(control, stats.summary());
        }
    }
    stats.summary()
}

/// A simulation faster than real time: every millisecond, run the cycles that are due so
/// that the daemon's clock advances `time_scale` times as fast as the wall clock on
/// average. Cycles the machine cannot run in time are dropped (the simulation then runs
/// slower than asked) and counted; the simulated clock itself never jumps.
fn run_batched(control: &mut ControlLoop, p: &Pacing, stop: &AtomicBool) -> PeriodSummary {
    let cycles_per_ns = p.rate_hz * p.time_scale * 1e-9;
    let max_batch = ((4 * BATCH_TICK_NS) as f64 * cycles_per_ns).ceil() as u64;
    let mut stats = PeriodStats::new(BATCH_TICK_NS);
    let report_every_ns = (p.report_every_s * 1e9) as i64;
    let start = MonoNs::now();
    let start_clock = control.now_s();
    let mut next_report = start.plus_ns(report_every_ns);
    let mut last_wake = start;
    let mut next = start.plus_ns(BATCH_TICK_NS);
    let mut run: u64 = 0;
    let mut dropped: u64 = 0;
    let summarize = |stats: &PeriodStats, control: &ControlLoop, now: MonoNs| {
        let mut s = stats.summary();
        s.batched = true;
        s.achieved_time_scale =
            (control.now_s() - start_clock) / (now.ns_since(start) as f64 * 1e-9).max(1e-9);
        s
    };

    while !stop.load(Ordering::Acquire) {
        os::sleep_until(next);
        let wake = MonoNs::now();
        stats.record_period(wake.ns_since(last_wake));
        last_wake = wake;

        let due = (wake.ns_since(start) as f64 * cycles_per_ns) as u64;
        let owed = due.saturating_sub(run + dropped);
        let n = owed.min(max_batch);
        for _ in 0..n {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            control.cycle();
        }
        run += n;
        if owed > n {
            dropped += owed - n;
            stats.record_overrun(owed - n);
            control.set_overruns(stats.overruns());
        }

        next = next.plus_ns(BATCH_TICK_NS);
        let end = MonoNs::now();
        if end > next {
            let skipped = end.ns_since(next) / BATCH_TICK_NS;
            next = next.plus_ns((skipped + 1) * BATCH_TICK_NS);
        }
        if end >= next_report {
            next_report = end.plus_ns(report_every_ns);
            let _ = control_events(control, summarize(&stats, control, end));
        }
    }
    summarize(&stats, control, MonoNs::now())
}

fn control_events(
    control: &mut ControlLoop,
    summary: crate::rt::period_stats::PeriodSummary,
) -> bool {
    control.report(ControlEvent::Timing {
        t_s: control.now_s(),
        summary,
    })
}
