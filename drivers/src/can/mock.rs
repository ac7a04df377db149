//! A mock CAN adapter for tests: frames and bus conditions are injected by hand, sent frames
//! wait in a transmit queue until the test lets the "controller" put them on the wire, and
//! the device can be unplugged and plugged in again.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

use super::adapter::{AdapterError, CanAdapter};
use super::frame::{BusEvent, DataFrame};

#[derive(Debug, Default)]
struct Inner {
    rx: VecDeque<BusEvent>,
    pending: VecDeque<DataFrame>,
    wire: Vec<DataFrame>,
    tx_capacity: usize,
    discards: u64,
    /// The device is gone: every call fails, reopening too.
    unplugged: bool,
    reopens: u64,
}

const UNPLUGGED: &str = "mock CAN bus: device unplugged";

/// Both the adapter (give a clone to the driver) and the test's handle on it.
#[derive(Debug, Clone)]
pub struct MockBus(Arc<Mutex<Inner>>);

impl MockBus {
    /// A bus whose controller holds at most `tx_capacity` frames waiting to be sent.
    pub fn new(tx_capacity: usize) -> Self {
        Self(Arc::new(Mutex::new(Inner {
            tx_capacity,
            ..Inner::default()
        })))
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn inject(&self, event: BusEvent) {
        self.lock().rx.push_back(event);
    }

    pub fn inject_frame(&self, frame: DataFrame) {
        self.inject(BusEvent::Frame(frame));
    }

    /// The controller transmits everything queued (the bus is up).
    pub fn transmit_pending(&self) {
        let mut g = self.lock();
        let sent: Vec<_> = g.pending.drain(..).collect();
        g.wire.extend(sent);
    }

    /// Frames that actually went out on the bus, oldest first.
    pub fn wire(&self) -> Vec<DataFrame> {
        self.lock().wire.clone()
    }

    /// Take the frames that went out on the bus.
    pub fn take_wire(&self) -> Vec<DataFrame> {
        std::mem::take(&mut self.lock().wire)
    }

    /// Frames queued but not yet transmitted.
    pub fn pending(&self) -> Vec<DataFrame> {
        self.lock().pending.iter().copied().collect()
    }

    pub fn discards(&self) -> u64 {
        self.lock().discards
    }

    /// The device goes away (USB cable pulled): every call fails until [`Self::replug`]
    /// and a reopen. What was queued either way is lost.
    pub fn unplug(&self) {
        let mut g = self.lock();
        g.unplugged = true;
        g.rx.clear();
        g.pending.clear();
    }

    /// The device is back; the driver still has to reopen it.
    pub fn replug(&self) {
        self.lock().unplugged = false;
    }

    /// Successful reopens so far.
    pub fn reopens(&self) -> u64 {
        self.lock().reopens
    }
}

fn gone() -> AdapterError {
    AdapterError::Io(UNPLUGGED.into())
}

impl CanAdapter for MockBus {
    fn recv(&mut self) -> Result<Option<BusEvent>, AdapterError> {
        let mut g = self.lock();
        if g.unplugged {
            return Err(gone());
        }
        Ok(g.rx.pop_front())
    }

    fn send(&mut self, frame: &DataFrame) -> Result<(), AdapterError> {
        let mut g = self.lock();
        if g.unplugged {
            return Err(gone());
        }
        if g.pending.len() >= g.tx_capacity {
            return Err(AdapterError::TxFull);
        }
        g.pending.push_back(*frame);
        Ok(())
    }

    fn discard_pending_tx(&mut self) -> Result<(), AdapterError> {
        let mut g = self.lock();
        if g.unplugged {
            return Err(gone());
        }
        g.pending.clear();
        g.discards += 1;
        Ok(())
    }

    fn describe(&self) -> String {
        "mock CAN bus".into()
    }

    fn reopen(&mut self) -> Result<(), AdapterError> {
        let mut g = self.lock();
        if g.unplugged {
            return Err(AdapterError::Io(format!(
                "cannot open the mock CAN bus: {UNPLUGGED}"
            )));
        }
        g.pending.clear();
        g.reopens += 1;
        Ok(())
    }
}
