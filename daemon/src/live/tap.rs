//! The supervisor's side of the live view: a bounded queue to the publisher that never
//! blocks (a full queue drops the message and counts it), the live clock, and which channels
//! anyone is subscribed to (so that nothing is built for nobody).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crossbeam_channel::{Receiver, Sender};

use crate::live::topics::LiveTopic;
use crate::recording::messages::TactileSample;
use crate::recording::trial_file::Epoch;

/// What the supervisor hands the publisher.
#[derive(Debug)]
pub enum LiveMsg {
    /// A message built as the recording builds it, on the live clock.
    Json {
        topic: LiveTopic,
        log_time_ns: u64,
        json: Vec<u8>,
    },
    /// A tactile frame: published raw, and band-passed by the publisher.
    Tactile {
        log_time_ns: u64,
        sample: TactileSample,
    },
    /// The trial's tracker reported a pulse period (`None`: the trial ended).
    Period(Option<f64>),
}

/// Counters shared by the tap and the publisher.
#[derive(Debug, Default)]
pub struct LiveCounters {
    /// Messages dropped because the queue was full.
    pub dropped: AtomicU64,
    /// One bit per [`LiveTopic::index`]: someone is subscribed (set by the publisher).
    pub wanted: AtomicU64,
}

/// The sending end, owned by the supervisor.
#[derive(Debug, Clone)]
pub struct LiveTap {
    tx: Sender<LiveMsg>,
    counters: Arc<LiveCounters>,
    epoch: Epoch,
    url: String,
}

impl LiveTap {
    /// A queue of `capacity` messages; the receiver goes to the publisher.
    pub fn new(
        capacity: usize,
        epoch: Epoch,
        url: String,
    ) -> (Self, Receiver<LiveMsg>, Arc<LiveCounters>) {
        let (tx, rx) = crossbeam_channel::bounded(capacity);
        let counters = Arc::new(LiveCounters::default());
        (
            Self {
                tx,
                counters: Arc::clone(&counters),
                epoch,
                url,
            },
            rx,
            counters,
        )
    }

    /// Queue `msg`, or drop and count it if the queue is full (or the publisher is gone).
    pub fn offer(&self, msg: LiveMsg) {
        if self.tx.try_send(msg).is_err() {
            self.counters.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Queue `msg`, waiting for room (a replay, which must not drop); false if the
    /// publisher is gone.
    pub fn send(&self, msg: LiveMsg) -> bool {
        self.tx.send(msg).is_ok()
    }

    /// Someone is subscribed to any channel.
    pub fn anyone_subscribed(&self) -> bool {
        self.counters.wanted.load(Ordering::Relaxed) != 0
    }

    /// Someone is subscribed to `topic`.
    pub fn wants(&self, topic: LiveTopic) -> bool {
        self.counters.wanted.load(Ordering::Relaxed) & (1 << topic.index()) != 0
    }

    pub fn dropped(&self) -> u64 {
        self.counters.dropped.load(Ordering::Relaxed)
    }

    /// The live clock: fixed when the daemon started.
    pub fn epoch(&self) -> Epoch {
        self.epoch
    }

    /// Where Foxglove connects: `ws://ADDRESS:PORT`.
    pub fn url(&self) -> &str {
        &self.url
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_queue_drops_and_counts_without_blocking() {
        let (tap, rx, counters) = LiveTap::new(4, Epoch { offset_ns: 0 }, "ws://x".into());
        for i in 0..10u64 {
            tap.offer(LiveMsg::Period(Some(i as f64)));
        }
        assert_eq!(tap.dropped(), 6);
        assert_eq!(rx.try_iter().count(), 4);
        drop(rx);
        tap.offer(LiveMsg::Period(None));
        assert_eq!(counters.dropped.load(Ordering::Relaxed), 7);
    }

    #[test]
    fn wants_reads_the_publishers_mask() {
        let (tap, _rx, counters) = LiveTap::new(4, Epoch { offset_ns: 0 }, "ws://x".into());
        assert!(!tap.wants(LiveTopic::Pulse));
        counters
            .wanted
            .store(1 << LiveTopic::Pulse.index(), Ordering::Relaxed);
        assert!(tap.wants(LiveTopic::Pulse));
        assert!(!tap.wants(LiveTopic::State));
    }
}
