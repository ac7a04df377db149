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
/// stops the feeding and systemd restarts the service.
pub async fn watchdog(status: Arc<Slot<ControlStatus>>, heartbeat: Arc<AtomicU64>) {
    let Some(interval) = sd_notify::watchdog_enabled() else {
        return;
    };
    let period = (interval / 2).max(Duration::from_millis(10));
    tracing::info!("systemd watchdog every {interval:?}; feeding every {period:?}");
    let mut last_cycle = 0u64;
    let mut last_beat = 0u64;
    let mut ticker = tokio::time::interval(period);
    loop {
        ticker.tick().await;
        let cycle = status.read().map(|s| s.cycle).unwrap_or(0);
        let beat = heartbeat.load(Ordering::Relaxed);
        if cycle > last_cycle && beat > last_beat {
            let _ = sd_notify::notify(&[NotifyState::Watchdog]);
        } else {
            tracing::error!(
                "not feeding the watchdog: control loop cycles {last_cycle} -> {cycle}, supervisor beats {last_beat} -> {beat}"
            );
        }
        last_cycle = cycle;
        last_beat = beat;
    }
}
