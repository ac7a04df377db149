//! Fan-out of stream events to subscribed console clients, and the reply path of requests.

use std::sync::Arc;

use serde_json::Value;
use tokio::sync::{broadcast, oneshot};

use crate::console::protocol::Stream;
use crate::recording::messages::ClientId;

/// Where the answer to one request goes, and who asked (recorded with the request).
#[derive(Debug)]
pub struct Responder {
    tx: oneshot::Sender<Value>,
    pub client: ClientId,
}

impl Responder {
    pub fn new(tx: oneshot::Sender<Value>, client: ClientId) -> Self {
        Self { tx, client }
    }

    /// Answer; a client that has gone away is not an error.
    pub fn send(self, reply: Value) {
        let _ = self.tx.send(reply);
    }
}

/// One event line for subscribers of `stream`.
#[derive(Debug, Clone)]
pub struct StreamEvent {
    pub stream: Stream,
    /// For tactile frames: the frame counter (decimation picks every n-th).
    pub counter: u64,
    /// The serialized JSON line, without its newline.
    pub line: String,
}

impl StreamEvent {
    pub fn new(stream: Stream, counter: u64, value: &Value) -> Arc<StreamEvent> {
        Arc::new(StreamEvent {
            stream,
            counter,
            line: value.to_string(),
        })
    }
}

/// A broadcast channel; slow subscribers lag (and are told how much) instead of slowing
/// anyone else down.
#[derive(Debug, Clone)]
pub struct StreamHub {
    tx: broadcast::Sender<Arc<StreamEvent>>,
}

impl Default for StreamHub {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamHub {
    pub fn new() -> Self {
        let (tx, _) = broadcast::channel(8192);
        Self { tx }
    }

    pub fn publish(&self, e: Arc<StreamEvent>) {
        // No subscriber is not an error.
        let _ = self.tx.send(e);
    }

    pub fn subscribe(&self) -> broadcast::Receiver<Arc<StreamEvent>> {
        self.tx.subscribe()
    }
}
