//! The console server: accepts local clients on a Unix socket (mode 0660; peers checked by
//! SO_PEERCRED against the allow-list, supplementary groups included), greets them, parses
//! each line, hands verbs to the supervisor and writes replies and subscribed events back. A
//! bad line of any kind gets an error reply; a flooding client gets `flood` errors; none of it
//! reaches the supervisor. Idle clients are disconnected, and one connection beyond
//! `max_clients` is always kept for `estop` and `status`, so a full console never locks out
//! an emergency stop. Every refusal says why.

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

use crate::console::hub::{Responder, StreamHub};
use crate::console::protocol::{
    ErrorCode, ParseLimits, Stream, Verb, error_reply, hello, ok_reply, parse_request,
};
use crate::recording::messages::ClientId;
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
    /// A client with no request and no subscription for this long is disconnected.
    pub idle_timeout: Duration,
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

/// How a connection is served.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Slot {
    Ordinary,
    /// The connection kept beyond `max_clients`: `estop` and `status` only.
    Reserved,
}

/// How long the reserved connection may sit idle: long enough to type an estop.
const RESERVED_IDLE: Duration = Duration::from_secs(10);

/// Serve until the task is dropped.
pub async fn serve(listener: UnixListener, settings: Arc<ServerSettings>, links: ServerLinks) {
    let clients = Arc::new(AtomicUsize::new(0));
    let reserved = Arc::new(AtomicUsize::new(0));
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
        let reserved = Arc::clone(&reserved);
        tokio::spawn(async move {
            if clients.fetch_add(1, Ordering::AcqRel) < settings.max_clients {
                client(stream, &settings, links, Slot::Ordinary).await;
                clients.fetch_sub(1, Ordering::AcqRel);
                return;
            }
            clients.fetch_sub(1, Ordering::AcqRel);
            if reserved.fetch_add(1, Ordering::AcqRel) == 0 {
                client(stream, &settings, links, Slot::Reserved).await;
                reserved.fetch_sub(1, Ordering::AcqRel);
                return;
            }
            reserved.fetch_sub(1, Ordering::AcqRel);
            let why = format!(
                "too many console clients: {} connected and the connection kept for estop/status is in use; idle clients are disconnected after {:.0} s (console.max_clients, console.idle_timeout_s)",
                settings.max_clients,
                settings.idle_timeout.as_secs_f64()
            );
            tracing::warn!("console: refused a client: {why}");
            refuse(stream, &why).await;
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
    admit_peer(
        cred.uid(),
        cred.gid(),
        crate::rt::os::effective_uid(),
        s,
        supplementary_groups,
    )
}

/// The groups a user belongs to, from the user database (SO_PEERCRED gives only the primary
/// group). Empty when the uid has no entry.
fn supplementary_groups(uid: u32, gid: u32) -> Vec<u32> {
    use nix::unistd::{Gid, Uid, User, getgrouplist};
    let Ok(Some(user)) = User::from_uid(Uid::from_raw(uid)) else {
        return Vec::new();
    };
    let Ok(name) = std::ffi::CString::new(user.name) else {
        return Vec::new();
    };
    getgrouplist(&name, Gid::from_raw(gid))
        .map(|g| g.into_iter().map(|g| g.as_raw()).collect())
        .unwrap_or_default()
}

/// Root, the daemon's own user, and the configured users and groups (primary or
/// supplementary) may connect.
fn admit_peer(
    uid: u32,
    gid: u32,
    own_uid: u32,
    s: &ServerSettings,
    groups_of: impl Fn(u32, u32) -> Vec<u32>,
) -> Result<(), String> {
    if uid == 0 || uid == own_uid || s.allowed_uids.contains(&uid) || s.allowed_gids.contains(&gid)
    {
        return Ok(());
    }
    let mut gids = groups_of(uid, gid);
    if gids.iter().any(|g| s.allowed_gids.contains(g)) {
        return Ok(());
    }
    if !gids.contains(&gid) {
        gids.insert(0, gid);
    }
    Err(format!(
        "uid {uid} with groups {gids:?} is not allowed: the daemon (uid {own_uid}) admits root, its own user, console.allowed_uids {:?} and console.allowed_gids {:?}",
        s.allowed_uids, s.allowed_gids
    ))
}

/// What a client subscribed to.
#[derive(Debug, Clone, Default)]
struct Subscription {
    streams: Vec<Stream>,
    tactile_every: u32,
}

async fn client(stream: UnixStream, s: &ServerSettings, links: ServerLinks, slot: Slot) {
    if let Err(why) = peer_allowed(&stream, s) {
        tracing::warn!("console: refused a client: {why}");
        refuse(stream, &why).await;
        return;
    }
    let client_id = stream
        .peer_cred()
        .map(|c| ClientId {
            uid: c.uid(),
            gid: c.gid(),
            pid: c.pid().unwrap_or(0),
        })
        .unwrap_or_default();
    let (read, mut write) = stream.into_split();
    let (out_tx, mut out_rx) = mpsc::channel::<String>(256);
    let (sub_tx, mut sub_rx) = watch::channel(Subscription::default());
    let mut events = links.hub.subscribe();

    let state = state_from_code(links.state.load(Ordering::Acquire));
    let mut greeting = hello(env!("CARGO_PKG_VERSION"), state.as_str(), s.backend_kind);
    if slot == Slot::Reserved
        && let Value::Object(o) = &mut greeting
    {
        o.insert(
            "restricted".into(),
            json!(format!(
                "the console is full ({} clients): this connection accepts only estop and status",
                s.max_clients
            )),
        );
    }
    let mut greeting = greeting.to_string();
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
    let idle = match slot {
        Slot::Ordinary => s.idle_timeout,
        Slot::Reserved => s.idle_timeout.min(RESERVED_IDLE),
    };
    let mut subscribed = false;
    loop {
        // A subscriber is a watcher, not idle; anyone else must say something now and then.
        let next = if subscribed {
            read_line(&mut reader, s.max_line_bytes).await
        } else {
            match tokio::time::timeout(idle, read_line(&mut reader, s.max_line_bytes)).await {
                Ok(r) => r,
                Err(_) => {
                    let why = format!(
                        "no request for {:.0} s: disconnected to free the slot (console.idle_timeout_s)",
                        idle.as_secs_f64()
                    );
                    send(&out_tx, error_reply(None, ErrorCode::Unavailable, &why)).await;
                    break;
                }
            }
        };
        let line = match next {
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
        if slot == Slot::Reserved && !matches!(req.verb, Verb::Estop | Verb::Status) {
            let why = format!(
                "the console is full ({} clients): this connection accepts only estop and status",
                s.max_clients
            );
            send(
                &out_tx,
                error_reply(Some(req.id), ErrorCode::Unavailable, &why),
            )
            .await;
            continue;
        }
        let reply = match &req.verb {
            Verb::Subscribe {
                streams,
                tactile_every,
            } => {
                subscribed = !streams.is_empty();
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
                subscribed = false;
                let _ = sub_tx.send(Subscription::default());
                ok_reply(req.id, json!({}))
            }
            _ => {
                ask(
                    &links.supervisor,
                    (req.id, client_id),
                    req.verb,
                    s.reply_timeout,
                )
                .await
            }
        };
        send(&out_tx, reply).await;
    }
    drop(out_tx);
    let _ = writer.await;
}

async fn send(out: &mpsc::Sender<String>, v: Value) {
    let _ = out.send(v.to_string()).await;
}

async fn ask(
    sup: &Sender<SupervisorInput>,
    (id, client): (u64, ClientId),
    verb: Verb,
    timeout: Duration,
) -> Value {
    let (tx, rx) = oneshot::channel();
    if sup
        .try_send(SupervisorInput::Request {
            id,
            verb,
            reply: Responder::new(tx, client),
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
/// up to its newline and reported, never buffered whole. A last line without its newline is
/// discarded: a client that closes mid-line did not finish its request.
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
            if !line.is_empty() || too_long {
                tracing::debug!(
                    "console: {seen} bytes without a newline before the close, discarded"
                );
            }
            return Ok(Line::Eof);
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
        assert_eq!(
            got,
            vec!["short", "too long 25", "ok"],
            "the unfinished line is dropped"
        );
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
            idle_timeout: Duration::from_secs(60),
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
        let none = |_, _| Vec::new();
        assert!(admit_peer(0, 0, own, &s, none).is_ok());
        assert!(admit_peer(own, 5, own, &s, none).is_ok());
        assert!(admit_peer(1001, 5, own, &s, none).is_ok());
        assert!(admit_peer(1500, 2000, own, &s, none).is_ok());
        // A member of the allowed group by a supplementary membership only.
        let member = |uid, gid| {
            if uid == 1600 {
                vec![gid, 2000]
            } else {
                vec![gid]
            }
        };
        assert!(admit_peer(1600, 1600, own, &s, member).is_ok());
        let e = admit_peer(1500, 1500, own, &s, member).expect_err("stranger");
        assert!(
            e.contains("uid 1500 with groups [1500] is not allowed")
                && e.contains("allowed_uids [1001]")
                && e.contains("allowed_gids [2000]"),
            "{e}"
        );
    }

    #[test]
    fn token_bucket_refuses_a_burst_beyond_the_rate() {
        let mut b = TokenBucket::new(10.0);
        let granted = (0..100).filter(|_| b.take()).count();
        assert!((10..=11).contains(&granted), "{granted}");
    }
}
