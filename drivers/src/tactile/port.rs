//! [`SerialTactileArray`]: control's `TactileArray` port over the serial task.

use std::sync::Arc;

use config::schema::SerialTactile;
use control::ports::TactileArray;
use control::types::TactileFrame;
use crossbeam_channel::{Receiver, TryRecvError};
use tokio::sync::watch;

use super::link::Link;
use super::status::{LinkState, LinkStatus, SharedStatus};
use crate::clock::Clock;

/// Why the tactile port has no frame to give.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TactileError {
    #[error("the tactile serial task has stopped")]
    LinkStopped,
    #[error("tactile array unusable: {0}")]
    Incompatible(String),
    #[error(
        "sensor.sample_rate_hz {0} is not a whole number of Hz in 1..=65535 (the protocol carries an integer rate)"
    )]
    BadRate(f64),
}

/// The tactile array on a serial line. Frames are decoded by a task on the given tokio
/// runtime and handed over through a bounded queue; [`TactileArray::poll_frame`] never
/// blocks. Dropping it stops the task.
#[derive(Debug)]
pub struct SerialTactileArray {
    rx: Receiver<TactileFrame>,
    status: SharedStatus,
    task: tokio::task::JoinHandle<()>,
    _stop: watch::Sender<()>,
}

impl SerialTactileArray {
    /// Start the serial task. `sample_rate_hz` is requested from the device in the
    /// handshake; `clock` stamps frames (the control loop's clock).
    pub fn spawn(
        runtime: &tokio::runtime::Handle,
        settings: &SerialTactile,
        sample_rate_hz: f64,
        clock: Arc<dyn Clock>,
    ) -> Result<Self, TactileError> {
        let rate_ok = sample_rate_hz.fract() == 0.0 && (1.0..=65535.0).contains(&sample_rate_hz);
        if !rate_ok {
            return Err(TactileError::BadRate(sample_rate_hz));
        }
        let (tx, rx) = crossbeam_channel::bounded(settings.queue_frames.max(1));
        let (stop_tx, stop_rx) = watch::channel(());
        let status = SharedStatus::default();
        let link = Link {
            settings: settings.clone(),
            rate_hz: sample_rate_hz as u16,
            clock,
            tx,
            drain: rx.clone(),
            status: status.clone(),
            stop: stop_rx,
        };
        let task = runtime.spawn(link.run());
        Ok(Self {
            rx,
            status,
            task,
            _stop: stop_tx,
        })
    }

    /// The link's state, counters and device.
    pub fn status(&self) -> LinkStatus {
        self.status.snapshot()
    }
}

impl TactileArray for SerialTactileArray {
    type Error = TactileError;

    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, TactileError> {
        match self.rx.try_recv() {
            Ok(frame) => Ok(Some(frame)),
            Err(TryRecvError::Disconnected) => Err(TactileError::LinkStopped),
            Err(TryRecvError::Empty) => {
                if self.task.is_finished() {
                    return Err(TactileError::LinkStopped);
                }
                if let LinkState::Incompatible(why) = &self.status.lock().state {
                    return Err(TactileError::Incompatible(why.clone()));
                }
                Ok(None)
            }
        }
    }
}
