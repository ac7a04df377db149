//! systemd integration: readiness, status, stopping, and a watchdog fed only while the
//! control loop and the supervisor both make progress. All calls are no-ops outside systemd
//! (no NOTIFY_SOCKET).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use sd_notify::NotifyState;

use crate::rt::link::ControlStatus;
use crate::slot::Slot;

pub fn ready(status: &str) {
    if let Err(e) = sd_notify::notify(&[NotifyState::Ready, NotifyState::Status(status)]) {
        tracing::warn!("sd_notify READY: {e}");
    }
}

pub fn stopping() {
    let _ = sd_notify::notify(&[NotifyState::Stopping]);
}

pub fn status(text: &str) {
    let _ = sd_notify::notify(&[NotifyState::Status(text)]);
}

/// Feed the watchdog at half its interval, but only if the loop's cycle counter and the
/// supervisor's heartbeat both advanced since the last feed: a hung loop or supervisor
/// stops the feeding and systemd restarts the service. Starving is logged when it starts
/// and when it ends, not every period.
pub async fn watchdog(status: Arc<Slot<ControlStatus>>, heartbeat: Arc<AtomicU64>) {
    let Some(interval) = sd_notify::watchdog_enabled() else {
        return;
    };
    let period = (interval / 2).max(Duration::from_millis(10));
    tracing::info!("systemd watchdog every {interval:?}; feeding every {period:?}");
    let progress = || {
        (
            status.read().map(|s| s.cycle).unwrap_or(0),
            heartbeat.load(Ordering::Relaxed),
        )
    };
    let mut ticker = tokio::time::interval(period);
    // The first tick completes at once: it only takes the baseline. Judged then, a loop
    // or supervisor that had not yet counted anything looked hung at every start.
    ticker.tick().await;
    let mut judge = Progress::new(progress());
    loop {
        ticker.tick().await;
        let (cycle, beat) = progress();
        match judge.next(cycle, beat) {
            Verdict::Feed => {
                let _ = sd_notify::notify(&[NotifyState::Watchdog]);
            }
            Verdict::FeedAgain => {
                tracing::info!("control loop and supervisor progress again: feeding the watchdog");
                let _ = sd_notify::notify(&[NotifyState::Watchdog]);
            }
            Verdict::Starve { from } => tracing::error!(
                "not feeding the watchdog: control loop cycles {} -> {cycle}, supervisor beats {} -> {beat}",
                from.0,
                from.1
            ),
            Verdict::StillStarving => {}
        }
    }
}

/// What to do at a watchdog period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Verdict {
    Feed,
    /// Progress after a starved period.
    FeedAgain,
    /// No progress since `from` (cycles, beats): stop feeding, say so once.
    Starve {
        from: (u64, u64),
    },
    StillStarving,
}

/// The last counts seen, and whether feeding has stopped.
#[derive(Debug, Clone, Copy)]
struct Progress {
    last: (u64, u64),
    starving: bool,
}

impl Progress {
    fn new(baseline: (u64, u64)) -> Self {
        Self {
            last: baseline,
            starving: false,
        }
    }

    fn next(&mut self, cycle: u64, beat: u64) -> Verdict {
        let from = self.last;
        self.last = (cycle, beat);
        let alive = cycle > from.0 && beat > from.1;
        match (alive, self.starving) {
            (true, false) => Verdict::Feed,
            (true, true) => {
                self.starving = false;
                Verdict::FeedAgain
            }
            (false, false) => {
                self.starving = true;
                Verdict::Starve { from }
            }
            (false, true) => Verdict::StillStarving,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feeds_while_both_progress_and_says_once_when_it_stops_and_resumes() {
        let mut p = Progress::new((10, 3));
        assert_eq!(p.next(20, 4), Verdict::Feed);
        assert_eq!(p.next(30, 4), Verdict::Starve { from: (20, 4) });
        assert_eq!(p.next(30, 4), Verdict::StillStarving);
        assert_eq!(
            p.next(30, 9),
            Verdict::StillStarving,
            "the loop is still hung"
        );
        assert_eq!(p.next(31, 10), Verdict::FeedAgain);
        assert_eq!(p.next(32, 11), Verdict::Feed);
    }
}
