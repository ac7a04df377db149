//! A blocking console client: the `pulsetrack` CLI and the end-to-end tests use it.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error(
        "cannot connect to {path}: {source} (is pulsetrackd running? see `console.socket_path`)"
    )]
    Connect {
        path: String,
        source: std::io::Error,
    },
    #[error("console connection: {0}")]
    Io(#[from] std::io::Error),
    #[error("the daemon sent a line that is not JSON: {0}")]
    BadLine(String),
    #[error("the daemon closed the connection")]
    Closed,
    #[error("no answer within {0:?}")]
    Timeout(Duration),
    #[error("{0}")]
    Refused(String),
    /// The socket is served by a process of a user we do not trust.
    #[error(
        "refusing to talk to {path}: it is served by uid {uid}, not by root, by you (uid {own}) or by the configured daemon user{trusted}; someone may have replaced the socket"
    )]
    Untrusted {
        path: String,
        uid: u32,
        own: u32,
        trusted: String,
    },
}

#[derive(Debug)]
pub struct Client {
    reader: BufReader<UnixStream>,
    writer: UnixStream,
    next_id: u64,
    /// Event lines that arrived while waiting for a reply.
    events: VecDeque<Value>,
    pub hello: Value,
}

impl Client {
    /// Connect and read the hello, if the socket is served by root or by this user.
    pub fn connect(path: &Path, timeout: Duration) -> Result<Client, ClientError> {
        Self::connect_trusting(path, timeout, &[])
    }

    /// Connect, check before sending anything that the process serving the socket runs as
    /// root, as this user or as one of `trusted_uids` (SO_PEERCRED of the server), then read
    /// the hello.
    pub fn connect_trusting(
        path: &Path,
        timeout: Duration,
        trusted_uids: &[u32],
    ) -> Result<Client, ClientError> {
        let stream = UnixStream::connect(path).map_err(|source| ClientError::Connect {
            path: path.display().to_string(),
            source,
        })?;
        let server =
            nix::sys::socket::getsockopt(&stream, nix::sys::socket::sockopt::PeerCredentials)
                .map_err(std::io::Error::from)?
                .uid();
        let own = nix::unistd::geteuid().as_raw();
        if server != 0 && server != own && !trusted_uids.contains(&server) {
            return Err(ClientError::Untrusted {
                path: path.display().to_string(),
                uid: server,
                own,
                trusted: if trusted_uids.is_empty() {
                    " (none configured: console.daemon_user)".into()
                } else {
                    format!(" {trusted_uids:?}")
                },
            });
        }
        let writer = stream.try_clone()?;
        let mut c = Client {
            reader: BufReader::new(stream),
            writer,
            next_id: 1,
            events: VecDeque::new(),
            hello: Value::Null,
        };
        let hello = c.read_line(timeout)?;
        if hello.get("hello").is_none() {
            let reason = hello["reason"].as_str().unwrap_or("no hello").to_string();
            return Err(ClientError::Refused(reason));
        }
        c.hello = hello;
        Ok(c)
    }

    fn read_line(&mut self, timeout: Duration) -> Result<Value, ClientError> {
        self.reader
            .get_ref()
            .set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        let mut line = String::new();
        match self.reader.read_line(&mut line) {
            Ok(0) => Err(ClientError::Closed),
            Ok(_) => serde_json::from_str(line.trim_end()).map_err(|_| ClientError::BadLine(line)),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                Err(ClientError::Timeout(timeout))
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Send raw bytes (tests use it for malformed lines).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), ClientError> {
        self.writer.write_all(bytes)?;
        Ok(())
    }

    /// Send a request (`verb` plus arguments) and wait for its reply (ok or not).
    pub fn request(
        &mut self,
        verb: &str,
        args: Value,
        timeout: Duration,
    ) -> Result<Value, ClientError> {
        let id = self.next_id;
        self.next_id += 1;
        let mut req = json!({"id": id, "verb": verb});
        if let (Value::Object(r), Value::Object(a)) = (&mut req, args) {
            r.extend(a);
        }
        let mut line = req.to_string();
        line.push('\n');
        self.writer.write_all(line.as_bytes())?;
        self.reply_to(Some(id), timeout)
    }

    /// Wait for the reply carrying `id` (or, with `None`, the next reply of any id), keeping
    /// events for [`Client::next_event`].
    pub fn reply_to(&mut self, id: Option<u64>, timeout: Duration) -> Result<Value, ClientError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ClientError::Timeout(timeout));
            }
            let v = self.read_line(left)?;
            if v.get("event").is_some() {
                self.events.push_back(v);
                continue;
            }
            if id.is_none() || v.get("id").and_then(Value::as_u64) == id {
                return Ok(v);
            }
        }
    }

    /// Like [`Client::request`], but an `ok: false` reply is an error carrying the reason.
    pub fn call(
        &mut self,
        verb: &str,
        args: Value,
        timeout: Duration,
    ) -> Result<Value, ClientError> {
        let r = self.request(verb, args, timeout)?;
        if r["ok"] == Value::Bool(true) {
            Ok(r)
        } else {
            Err(ClientError::Refused(format!(
                "{verb}: {} ({})",
                r["reason"].as_str().unwrap_or("refused"),
                r["error"].as_str().unwrap_or("error")
            )))
        }
    }

    /// The next event line, waiting up to `timeout`; `Ok(None)` on timeout.
    pub fn next_event(&mut self, timeout: Duration) -> Result<Option<Value>, ClientError> {
        if let Some(e) = self.events.pop_front() {
            return Ok(Some(e));
        }
        match self.read_line(timeout) {
            Ok(v) => {
                if v.get("event").is_some() {
                    Ok(Some(v))
                } else {
                    Ok(None)
                }
            }
            Err(ClientError::Timeout(_)) => Ok(None),
            Err(e) => Err(e),
        }
    }
}
