//! What the serial link reports about itself: its state, its counters, the device.

use std::sync::{Arc, Mutex, MutexGuard};

use super::wire::DeviceInfo;

/// Counters since the driver started. Every bad input of every kind lands in one of them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TactileStats {
    pub bytes: u64,
    /// Frames handed to the consumer.
    pub frames: u64,
    pub crc_errors: u64,
    /// Broken COBS, truncated or over-long frames, wrong body length for the type.
    pub framing_errors: u64,
    /// Frames of a type the host does not expect from a device.
    pub unexpected_messages: u64,
    pub wrong_channel_count: u64,
    /// An element beyond the configured force range.
    pub out_of_range: u64,
    /// An element the device marks as faulty.
    pub element_faults: u64,
    /// Places where frames went missing, and how many went missing in all.
    pub gaps: u64,
    pub missing_frames: u64,
    pub duplicates: u64,
    pub reordered: u64,
    /// The device's sequence counter restarted.
    pub resyncs: u64,
    /// Frames dropped because the consumer fell behind (oldest dropped first).
    pub queue_drops: u64,
    /// Force frames that arrived before the device had answered the handshake.
    pub before_handshake: u64,
    pub open_failures: u64,
    pub unplugs: u64,
    pub handshakes: u64,
    pub handshake_timeouts: u64,
    pub stale_events: u64,
}

/// Where the link is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkState {
    /// Opening the port (or waiting to retry).
    Opening,
    /// Port open, waiting for the device to answer the configure message.
    Handshaking,
    Streaming,
    /// Handshake done but no valid frame for longer than `stale_after_s`.
    Stale,
    /// The device answered but cannot be used as configured; the reason says why.
    Incompatible(String),
}

/// A snapshot of the link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkStatus {
    pub state: LinkState,
    pub stats: TactileStats,
    pub device: Option<DeviceInfo>,
    /// The most recent problem, in words.
    pub last_problem: Option<String>,
}

impl Default for LinkStatus {
    fn default() -> Self {
        Self {
            state: LinkState::Opening,
            stats: TactileStats::default(),
            device: None,
            last_problem: None,
        }
    }
}

/// The status shared between the serial task and the port.
#[derive(Debug, Clone, Default)]
pub struct SharedStatus(Arc<Mutex<LinkStatus>>);

impl SharedStatus {
    /// Lock it; a panic elsewhere while holding the lock leaves counters that are still
    /// meaningful, so poisoning is ignored.
    pub fn lock(&self) -> MutexGuard<'_, LinkStatus> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn snapshot(&self) -> LinkStatus {
        self.lock().clone()
    }

    pub fn update(&self, f: impl FnOnce(&mut LinkStatus)) {
        f(&mut self.lock());
    }
}
