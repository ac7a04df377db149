//! The console server: accepts local clients on a Unix socket (mode 0660; peers checked by
//! SO_PEERCRED against the allow-list), greets them, parses each line, hands verbs to the
//! supervisor and writes replies and subscribed events back. A bad line of any kind gets an
//! error reply; a flooding client gets `flood` errors; none of it reaches the supervisor.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use crossbeam_channel::Sender;
use serde_json::{Value, json};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::{UnixListener, UnixStream};
use tokio::sync::{mpsc, oneshot, watch};

use crate::console::hub::StreamHub;
use crate::console::protocol::{
    ErrorCode, ParseLimits, Stream, Verb, error_reply, hello, ok_reply, parse_request,
};
use crate::supervisor::{SupervisorInput, state_from_code};

/// What the server needs from config and the rest of the daemon.
#[derive(Debug, Clone)]
pub struct ServerSettings {
    pub socket_path: PathBuf,
    pub allowed_uids: Vec<u32>,
    pub allowed_gids: Vec<u32>,
    pub max_line_bytes: usize,
    pub max_requests_per_s: f64,
    pub max_clients: usize,
    pub limits: ParseLimits,
    pub backend_kind: &'static str,
    /// Wall time to wait for the supervisor's answer.
    pub reply_timeout: Duration,
}

#[derive(Debug, Clone)]
pub struct ServerLinks {
    pub supervisor: Sender<SupervisorInput>,
    pub hub: StreamHub,
    pub state: Arc<AtomicU8>,
}

/// Bind the socket: refuse if another daemon answers on it, replace a stale one.
pub async fn bind(path: &Path) -> std::io::Result<UnixListener> {
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir)?;
    }
    if path.exists() {
        if UnixStream::connect(path).await.is_ok() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::AddrInUse,
                format!("{} is in use by a running daemon", path.display()),
            ));
        }
        std::fs::remove_file(path)?;
    }
    let listener = UnixListener::bind(path)?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o660))?;
    Ok(listener)
}

/// Serve until the task is dropped.
pub async fn serve(listener: UnixListener, settings: Arc<ServerSettings>, links: ServerLinks) {
    let clients = Arc::new(AtomicUsize::new(0));
    loop {
        let (stream, _) = match listener.accept().await {
            Ok(s) => s,
            Err(e) => {
                tracing::warn!("console accept: {e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let settings = Arc::clone(&settings);
        let links = links.clone();
        let clients = Arc::clone(&clients);
        tokio::spawn(async move {
            if clients.fetch_add(1, Ordering::AcqRel) >= settings.max_clients {
                clients.fetch_sub(1, Ordering::AcqRel);
                refuse(stream, "too many console clients").await;
                return;
            }
            client(stream, &settings, links).await;
            clients.fetch_sub(1, Ordering::AcqRel);
        });
    }
}

async fn refuse(mut stream: UnixStream, why: &str) {
    let mut line = error_reply(None, ErrorCode::Unavailable, why).to_string();
    line.push('\n');
    let _ = stream.write_all(line.as_bytes()).await;
}

fn peer_allowed(stream: &UnixStream, s: &ServerSettings) -> Result<(), String> {
    let cred = stream
        .peer_cred()
        .map_err(|e| format!("cannot read peer credentials: {e}"))?;
    admit_peer(cred.uid(), cred.gid(), crate::rt::os::effective_uid(), s)
}

/// Root, the daemon's own user, and the configured users and groups may connect.
fn admit_peer(uid: u32, gid: u32, own_uid: u32, s: &ServerSettings) -> Result<(), String> {
    if uid == 0 || uid == own_uid || s.allowed_uids.contains(&uid) || s.allowed_gids.contains(&gid)
    {
        Ok(())
    } else {
        Err(format!(
            "uid {uid} gid {gid} is not allowed (console.allowed_uids / allowed_gids)"
        ))
    }
}

/// What a client subscribed to.
#[derive(Debug, Clone, Default)]
struct Subscription {
    streams: Vec<Stream>,
    tactile_every: u32,
}

async fn client(stream: UnixStream, s: &ServerSettings, links: ServerLinks) {
    if let Err(why) = peer_allowed(&stream, s) {
        tracing::warn!("console: refused a client: {why}");
        refuse(stream, &why).await;
        return;
    }
    let (read, mut write) = stream.into_split();
    let (out_tx, mut out_rx) = mpsc::channel::<String>(256);
    let (sub_tx, mut sub_rx) = watch::channel(Subscription::default());
    let mut events = links.hub.subscribe();

    let state = state_from_code(links.state.load(Ordering::Acquire));
    let mut greeting = hello(env!("CARGO_PKG_VERSION"), state.as_str(), s.backend_kind).to_string();
    greeting.push('\n');
    if write.write_all(greeting.as_bytes()).await.is_err() {
        return;
    }

    // The writer: replies in order, and subscribed events.
    let writer = tokio::spawn(async move {
        let mut sub = Subscription::default();
        loop {
            tokio::select! {
                line = out_rx.recv() => {
                    let Some(mut line) = line else { break };
                    line.push('\n');
                    if write.write_all(line.as_bytes()).await.is_err() { break; }
                }
                changed = sub_rx.changed() => {
                    if changed.is_err() { break; }
                    sub = sub_rx.borrow().clone();
                }
                ev = events.recv() => {
                    match ev {
                        Ok(e) => {
                            if !sub.streams.contains(&e.stream) { continue; }
                            if e.stream == Stream::Tactile
                                && e.counter % u64::from(sub.tactile_every.max(1)) != 0 {
                                continue;
                            }
                            let mut line = String::with_capacity(e.line.len() + 1);
                            line.push_str(&e.line);
                            line.push('\n');
                            if write.write_all(line.as_bytes()).await.is_err() { break; }
                        }
                        Err(tokio::sync::broadcast::error::RecvError::Lagged(n)) => {
                            if sub.streams.is_empty() { continue; }
                            let line = format!("{}\n", json!({"event": "lagged", "dropped": n}));
                            if write.write_all(line.as_bytes()).await.is_err() { break; }
                        }
                        Err(tokio::sync::broadcast::error::RecvError::Closed) => break,
                    }
                }
            }
        }
    });

    let mut reader = BufReader::new(read);
    let mut bucket = TokenBucket::new(s.max_requests_per_s);
    loop {
        let line = match read_line(&mut reader, s.max_line_bytes).await {
            Ok(Line::Eof) => break,
            Ok(Line::TooLong(n)) => {
                let why = format!(
                    "line of {n}+ bytes exceeds the limit of {} bytes; discarded",
                    s.max_line_bytes
                );
                send(&out_tx, error_reply(None, ErrorCode::LineTooLong, &why)).await;
                continue;
            }
            Ok(Line::Text(l)) => l,
            Err(_) => break,
        };
        if line.iter().all(|b| b.is_ascii_whitespace()) {
            continue;
        }
        if !bucket.take() {
            let why = format!(
                "more than {} requests per second; slow down",
                s.max_requests_per_s
            );
            send(&out_tx, error_reply(None, ErrorCode::Flood, &why)).await;
            continue;
        }
        let req = match parse_request(&line, &s.limits) {
            Ok(r) => r,
            Err(e) => {
                send(&out_tx, error_reply(e.id, e.code, &e.reason)).await;
                continue;
            }
        };
        let reply = match &req.verb {
            Verb::Subscribe {
                streams,
                tactile_every,
            } => {
                let _ = sub_tx.send(Subscription {
                    streams: streams.clone(),
                    tactile_every: *tactile_every,
                });
                ok_reply(
                    req.id,
                    json!({"streams": streams, "tactile_every": tactile_every}),
                )
            }
            Verb::Unsubscribe => {
                let _ = sub_tx.send(Subscription::default());
                ok_reply(req.id, json!({}))
            }
            _ => ask(&links.supervisor, req.id, req.verb, s.reply_timeout).await,
        };
        send(&out_tx, reply).await;
    }
    drop(out_tx);
    let _ = writer.await;
}

async fn send(out: &mpsc::Sender<String>, v: Value) {
    let _ = out.send(v.to_string()).await;
}

async fn ask(sup: &Sender<SupervisorInput>, id: u64, verb: Verb, timeout: Duration) -> Value {
    let (tx, rx) = oneshot::channel();
    if sup
        .try_send(SupervisorInput::Request {
            id,
            verb,
            reply: tx,
        })
        .is_err()
    {
        return error_reply(
            Some(id),
            ErrorCode::Unavailable,
            "the daemon is busy or stopping",
        );
    }
    match tokio::time::timeout(timeout, rx).await {
        Ok(Ok(v)) => v,
        Ok(Err(_)) => error_reply(Some(id), ErrorCode::Unavailable, "the daemon is stopping"),
        Err(_) => error_reply(Some(id), ErrorCode::Unavailable, "no answer in time"),
    }
}

enum Line {
    Text(Vec<u8>),
    TooLong(usize),
    Eof,
}

/// Read one line of at most `max` bytes (without its newline). A longer line is consumed
/// up to its newline and reported, never buffered whole.
async fn read_line<R: tokio::io::AsyncBufRead + Unpin>(
    r: &mut R,
    max: usize,
) -> std::io::Result<Line> {
    let mut line = Vec::new();
    let mut too_long = false;
    let mut seen = 0usize;
    loop {
        let buf = r.fill_buf().await?;
        if buf.is_empty() {
            return Ok(if too_long {
                Line::TooLong(seen)
            } else if line.is_empty() {
                Line::Eof
            } else {
                Line::Text(line)
            });
        }
        let (chunk, found) = match buf.iter().position(|b| *b == b'\n') {
            Some(i) => (&buf[..i], Some(i)),
            None => (buf, None),
        };
        seen += chunk.len();
        if !too_long {
            if line.len() + chunk.len() > max {
                too_long = true;
                line.clear();
            } else {
                line.extend_from_slice(chunk);
            }
        }
        let consumed = found.map(|i| i + 1).unwrap_or(chunk.len());
        r.consume(consumed);
        if found.is_some() {
            return Ok(if too_long {
                Line::TooLong(seen)
            } else {
                Line::Text(line)
            });
        }
    }
}

/// Requests per second with a burst of one second's worth.
#[derive(Debug)]
struct TokenBucket {
    rate: f64,
    tokens: f64,
    last: Instant,
}

impl TokenBucket {
    fn new(rate: f64) -> Self {
        Self {
            rate,
            tokens: rate,
            last: Instant::now(),
        }
    }

    fn take(&mut self) -> bool {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64();
        self.last = now;
        self.tokens = (self.tokens + dt * self.rate).min(self.rate);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn lines_longer_than_the_limit_are_skipped_whole() {
        let data: &[u8] = b"short\nthis line is far too long\nok\nno-newline";
        let mut r = BufReader::with_capacity(4, data);
        let mut got = Vec::new();
        loop {
            match read_line(&mut r, 10).await.expect("read") {
                Line::Eof => break,
                Line::Text(t) => got.push(String::from_utf8(t).expect("utf8")),
                Line::TooLong(n) => got.push(format!("too long {n}")),
            }
        }
        assert_eq!(got, vec!["short", "too long 25", "ok", "no-newline"]);
    }

    #[test]
    fn peers_are_admitted_by_uid_and_gid_allow_lists() {
        let s = ServerSettings {
            socket_path: PathBuf::from("/tmp/x.sock"),
            allowed_uids: vec![1001],
            allowed_gids: vec![2000],
            max_line_bytes: 1024,
            max_requests_per_s: 10.0,
            max_clients: 4,
            limits: ParseLimits {
                max_jog_m: 0.01,
                max_speed_m_s: 0.03,
                max_coordinate_m: 1.0,
                max_track_length_m: 2.0,
            },
            backend_kind: "sim",
            reply_timeout: Duration::from_secs(1),
        };
        let own = 990;
        assert!(admit_peer(0, 0, own, &s).is_ok());
        assert!(admit_peer(own, 5, own, &s).is_ok());
        assert!(admit_peer(1001, 5, own, &s).is_ok());
        assert!(admit_peer(1500, 2000, own, &s).is_ok());
        let e = admit_peer(1500, 1500, own, &s).expect_err("stranger");
        assert!(e.contains("uid 1500 gid 1500 is not allowed"), "{e}");
    }

    #[test]
    fn token_bucket_refuses_a_burst_beyond_the_rate() {
        let mut b = TokenBucket::new(10.0);
        let granted = (0..100).filter(|_| b.take()).count();
        assert!((10..=11).contains(&granted), "{granted}");
    }
}
