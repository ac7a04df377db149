//! The small interface every CAN adapter offers the driver: non-blocking receive and send,
//! discarding frames queued for transmission, and reopening a device that went away.

use super::frame::{BusEvent, DataFrame};

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AdapterError {
    /// The transmit queue is full (the bus is saturated, disconnected or off).
    #[error("transmit queue full")]
    TxFull,
    #[error("{0}")]
    Io(String),
}

/// A CAN interface. Every call returns at once.
pub trait CanAdapter: Send {
    /// The next received frame or bus condition, if any.
    fn recv(&mut self) -> Result<Option<BusEvent>, AdapterError>;

    /// Queue a frame for transmission.
    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError>;

    /// Drop every frame queued but not yet on the bus, as far as the adapter can reach.
    fn discard_pending_tx(&mut self) -> Result<(), AdapterError>;

    /// What this adapter is, for messages ("SocketCAN can0").
    fn describe(&self) -> String;

    /// Open the device again after it failed (unplugged, interface gone), from the settings
    /// it was opened with. Returns at once: it does not wait for the device to answer (the
    /// driver sees the bus come back as feedback arrives). On an error the adapter stays
    /// unusable and the error says why, for the operator.
    fn reopen(&mut self) -> Result<(), AdapterError>;
}

impl<A: CanAdapter + ?Sized> CanAdapter for Box<A> {
    fn recv(&mut self) -> Result<Option<BusEvent>, AdapterError> {
        (**self).recv()
    }
    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError> {
        (**self).send(frame)
    }
    fn discard_pending_tx(&mut self) -> Result<(), AdapterError> {
        (**self).discard_pending_tx()
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
    fn reopen(&mut self) -> Result<(), AdapterError> {
        (**self).reopen()
    }
}
