//! A small client of the Foxglove WebSocket protocol, written from the published
//! specification (foxglove/ws-protocol, docs/spec.md) rather than with the SDK the daemon
//! serves it with, so that the tests judge the daemon as an independent viewer would: JSON
//! `serverInfo`, `advertise` (schemas inline) and `subscribe`, binary message data (opcode 1:
//! subscription id u32 LE, log time u64 LE ns, then the message).
//!
//! The specification's subprotocol was `foxglove.websocket.v1`; the SDK's server (0.30) speaks
//! the same messages under the name `foxglove.sdk.v1` and refuses the old name. The client
//! offers both, as Foxglove's own app does, and insists on the one with inline schemas.

use std::collections::BTreeMap;
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

/// The subprotocol this client needs the server to choose.
pub const SUBPROTOCOL: &str = "foxglove.sdk.v1";

/// What the client offers: the current name first, then the specification's original one.
const OFFERED: &str = "foxglove.sdk.v1, foxglove.websocket.v1";

/// A channel the server advertised.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    pub id: u64,
    pub topic: String,
    pub encoding: String,
    pub schema_name: String,
    pub schema: String,
}

/// One message received on a subscription.
#[derive(Debug, Clone, PartialEq)]
pub struct Received {
    pub topic: String,
    pub log_time_ns: u64,
    pub payload: Vec<u8>,
}

impl Received {
    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.payload).unwrap_or(Value::Null)
    }
}

pub struct FoxgloveClient {
    ws: WebSocket<TcpStream>,
    pub server_info: Value,
    /// Advertised channels by id.
    pub channels: BTreeMap<u64, Channel>,
    /// Subscription id -> topic.
    subscriptions: BTreeMap<u32, String>,
    next_sub: u32,
}

impl std::fmt::Debug for FoxgloveClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FoxgloveClient")
            .field("channels", &self.channels.len())
            .finish()
    }
}

impl FoxgloveClient {
    /// Connect to `ws://HOST:PORT` and read the server's greeting.
    pub fn connect(url: &str, timeout: Duration) -> Result<Self, String> {
        let addr: SocketAddr = url
            .strip_prefix("ws://")
            .ok_or_else(|| format!("{url}: not a ws:// URL"))?
            .trim_end_matches('/')
            .parse()
            .map_err(|e| format!("{url}: {e}"))?;
        let tcp = TcpStream::connect_timeout(&addr, timeout).map_err(|e| format!("{url}: {e}"))?;
        tcp.set_read_timeout(Some(timeout))
            .map_err(|e| e.to_string())?;
        let mut request = url.into_client_request().map_err(|e| e.to_string())?;
        request.headers_mut().insert(
            "Sec-WebSocket-Protocol",
            OFFERED.parse().map_err(|_| "header")?,
        );
        let (ws, response) =
            tungstenite::client(request, tcp).map_err(|e| format!("handshake: {e}"))?;
        let agreed = response
            .headers()
            .get("Sec-WebSocket-Protocol")
            .and_then(|v| v.to_str().ok())
            .unwrap_or("");
        if agreed != SUBPROTOCOL {
            return Err(format!(
                "the server agreed to {agreed:?}, not {SUBPROTOCOL}"
            ));
        }
        let mut c = Self {
            ws,
            server_info: Value::Null,
            channels: BTreeMap::new(),
            subscriptions: BTreeMap::new(),
            next_sub: 1,
        };
        let deadline = Instant::now() + timeout;
        while c.server_info.is_null() {
            if Instant::now() > deadline {
                return Err("no serverInfo".into());
            }
            c.read_one(Duration::from_millis(100))?;
        }
        Ok(c)
    }

    /// Read until every topic in `topics` is advertised.
    pub fn wait_for_channels(&mut self, topics: &[&str], timeout: Duration) -> Result<(), String> {
        let deadline = Instant::now() + timeout;
        loop {
            let missing: Vec<&&str> = topics
                .iter()
                .filter(|t| !self.channels.values().any(|c| c.topic == **t))
                .collect();
            if missing.is_empty() {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(format!("not advertised: {missing:?}"));
            }
            self.read_one(Duration::from_millis(100))?;
        }
    }

    /// The advertised channel on `topic`.
    pub fn channel(&self, topic: &str) -> Option<&Channel> {
        self.channels.values().find(|c| c.topic == topic)
    }

    /// Subscribe to these advertised topics.
    pub fn subscribe(&mut self, topics: &[&str]) -> Result<(), String> {
        let mut subs = Vec::new();
        for t in topics {
            let ch = self
                .channel(t)
                .ok_or_else(|| format!("{t} is not advertised"))?
                .id;
            let id = self.next_sub;
            self.next_sub += 1;
            self.subscriptions.insert(id, (*t).to_string());
            subs.push(json!({"id": id, "channelId": ch}));
        }
        let msg = json!({"op": "subscribe", "subscriptions": subs});
        self.ws
            .send(Message::text(msg.to_string()))
            .map_err(|e| e.to_string())
    }

    /// The next message on a subscription, or `None` after `timeout` with none.
    pub fn next(&mut self, timeout: Duration) -> Result<Option<Received>, String> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(r) = self.read_one(Duration::from_millis(50))? {
                return Ok(Some(r));
            }
            if Instant::now() > deadline {
                return Ok(None);
            }
        }
    }

    /// Every message received within `span`.
    pub fn collect_for(&mut self, span: Duration) -> Result<Vec<Received>, String> {
        let deadline = Instant::now() + span;
        let mut out = Vec::new();
        while Instant::now() < deadline {
            if let Some(r) = self.read_one(Duration::from_millis(50))? {
                out.push(r);
            }
        }
        Ok(out)
    }

    /// Read one frame (waiting up to about `wait`): a message on a subscription is returned,
    /// anything else updates the client's state.
    fn read_one(&mut self, wait: Duration) -> Result<Option<Received>, String> {
        self.ws
            .get_mut()
            .set_read_timeout(Some(wait))
            .map_err(|e| e.to_string())?;
        let frame = match self.ws.read() {
            Ok(f) => f,
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(None);
            }
            Err(e) => return Err(format!("read: {e}")),
        };
        match frame {
            Message::Text(text) => {
                let v: Value = serde_json::from_str(&text).map_err(|e| format!("{e}: {text}"))?;
                match v["op"].as_str() {
                    Some("serverInfo") => self.server_info = v,
                    Some("advertise") => {
                        for c in v["channels"].as_array().into_iter().flatten() {
                            let ch = Channel {
                                id: c["id"].as_u64().ok_or("channel without id")?,
                                topic: c["topic"].as_str().unwrap_or("").to_string(),
                                encoding: c["encoding"].as_str().unwrap_or("").to_string(),
                                schema_name: c["schemaName"].as_str().unwrap_or("").to_string(),
                                schema: c["schema"].as_str().unwrap_or("").to_string(),
                            };
                            self.channels.insert(ch.id, ch);
                        }
                    }
                    Some("unadvertise") => {
                        for id in v["channelIds"].as_array().into_iter().flatten() {
                            if let Some(id) = id.as_u64() {
                                self.channels.remove(&id);
                            }
                        }
                    }
                    _ => {}
                }
                Ok(None)
            }
            Message::Binary(b) => {
                if b.first() != Some(&1) || b.len() < 13 {
                    return Ok(None);
                }
                let sub = u32::from_le_bytes([b[1], b[2], b[3], b[4]]);
                let mut t = [0u8; 8];
                t.copy_from_slice(&b[5..13]);
                let Some(topic) = self.subscriptions.get(&sub) else {
                    return Err(format!("data on unknown subscription {sub}"));
                };
                Ok(Some(Received {
                    topic: topic.clone(),
                    log_time_ns: u64::from_le_bytes(t),
                    payload: b[13..].to_vec(),
                }))
            }
            Message::Close(c) => Err(format!("the server closed the connection: {c:?}")),
            _ => Ok(None),
        }
    }
}

/// Every channel the daemon's live view advertises (docs/foxglove.md).
pub const LIVE_TOPICS: [&str; 13] = [
    "/joints",
    "/tactile",
    "/events",
    "/truth",
    "/log",
    "/sensor/believed",
    "/sensor/true",
    "/artery",
    "/tf",
    "/tactile/bandpassed",
    "/pulse",
    "/loop",
    "/state",
];
