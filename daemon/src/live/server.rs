//! Starting and stopping the live view: the `foxglove` SDK's WebSocket server on a runtime
//! of its own (a client that misbehaves cannot starve the console's), the live channels and
//! the publisher thread, and the [`LiveTap`] the supervisor feeds.

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;

use control::signal::BandPassSpec;
use foxglove::{Context, WebSocketServer, WebSocketServerHandle};

use crate::live::bandpass::LiveBandPass;
use crate::live::publisher::{Publisher, channels};
use crate::live::tap::LiveTap;
use crate::recording::trial_file::Epoch;

/// How the pulse swing and the beats are measured: over this many seconds of band-passed
/// frames (three beats of a heart at 60 per minute, two of them confirmed peaks).
const SWING_WINDOW_S: f64 = 3.0;

/// How long clients get to close when the server stops.
const STOP_WAIT: std::time::Duration = std::time::Duration::from_secs(1);

/// What the live view needs.
#[derive(Debug, Clone)]
pub struct LiveSettings {
    pub address: IpAddr,
    /// 0: any free port.
    pub port: u16,
    pub queue_messages: usize,
    /// The band-pass for `/tactile/bandpassed` and `/pulse` (`None`: raw frames only).
    pub band: Option<BandPassSpec>,
    /// The tactile array's rate, Hz.
    pub sample_rate_hz: f64,
    pub epoch: Epoch,
    /// The server's name as Foxglove shows it.
    pub name: String,
}

impl LiveSettings {
    /// The daemon's live view from its configuration, on the clock `epoch`.
    pub fn from_config(c: &config::Config, epoch: Epoch) -> Result<Self, LiveError> {
        let address = c
            .live
            .ip()
            .ok_or_else(|| LiveError::Address(c.live.address.clone()))?;
        let p = &c.tracker.params.seed2002;
        Ok(Self {
            address,
            port: c.live.port,
            queue_messages: c.live.queue_messages,
            band: Some(BandPassSpec {
                order: p.fir_order,
                low_hz: p.band_low_hz,
                high_hz: p.band_high_hz,
                sample_rate_hz: c.sensor.sample_rate_hz,
            }),
            sample_rate_hz: c.sensor.sample_rate_hz,
            epoch,
            name: "pulsetrackd".into(),
        })
    }
}

/// Why the live view did not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error("live.address: {0:?} is not an IP address")]
    Address(String),
    #[error("live view: starting its runtime: {0}")]
    Runtime(std::io::Error),
    #[error("live view: cannot serve on {addr} (live.address, live.port): {source}")]
    Bind {
        addr: SocketAddr,
        source: foxglove::FoxgloveError,
    },
    #[error("live view: {0}")]
    Foxglove(#[from] foxglove::FoxgloveError),
    #[error("live view: starting the publisher thread: {0}")]
    Thread(std::io::Error),
}

/// A running live view.
pub struct LiveServer {
    runtime: Option<tokio::runtime::Runtime>,
    handle: Option<WebSocketServerHandle>,
    publisher: Option<std::thread::JoinHandle<()>>,
    url: String,
    _context: Arc<Context>,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer")
            .field("url", &self.url)
            .finish()
    }
}

impl LiveServer {
    /// Bind, start serving and start the publisher. The tap's last clone going away stops
    /// the publisher; [`LiveServer::stop`] then closes the server.
    pub fn start(s: &LiveSettings) -> Result<(LiveServer, LiveTap), LiveError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("pulsetrack-live")
            .enable_all()
            .build()
            .map_err(LiveError::Runtime)?;
        let context = Context::new();
        let channels = channels(&context)?;
        let addr = SocketAddr::new(s.address, s.port);
        let handle = runtime
            .block_on(
                WebSocketServer::new()
                    .name(&s.name)
                    .bind(s.address.to_string(), s.port)
                    .context(&context)
                    .start(),
            )
            .map_err(|source| LiveError::Bind { addr, source })?;
        let url = format!("ws://{}", SocketAddr::new(s.address, handle.port()));
        let bandpass = s
            .band
            .and_then(|spec| match LiveBandPass::new(spec, SWING_WINDOW_S) {
                Ok(b) => Some(b),
                Err(e) => {
                    tracing::warn!(
                        "live view: no band-passed frames or pulse ({e}); raw frames only"
                    );
                    None
                }
            });
        let (tap, inbox, counters) = LiveTap::new(s.queue_messages, s.epoch, url.clone());
        let publisher = Publisher::new(channels, counters, bandpass, s.sample_rate_hz, s.epoch);
        let publisher = std::thread::Builder::new()
            .name("pulsetrack-pub".into())
            .spawn(move || publisher.run(inbox))
            .map_err(LiveError::Thread)?;
        tracing::info!("live view on {url} (Foxglove: Open connection, Foxglove WebSocket)");
        Ok((
            LiveServer {
                runtime: Some(runtime),
                handle: Some(handle),
                publisher: Some(publisher),
                url,
                _context: context,
            },
            tap,
        ))
    }

    /// `ws://ADDRESS:PORT`.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Clients connected now.
    pub fn client_count(&self) -> usize {
        self.handle.as_ref().map_or(0, |h| h.client_count())
    }

    /// Close the server (clients are disconnected) and, once every tap is gone, the publisher.
    pub fn stop(mut self) {
        self.shut_down(true);
    }

    /// `join`: wait for the publisher (its taps must be gone, or this waits for them).
    fn shut_down(&mut self, join: bool) {
        if let (Some(h), Some(rt)) = (self.handle.take(), self.runtime.as_ref()) {
            // A client that stopped reading never finishes its close: give the clients a
            // moment, then drop their tasks (dropping the wait aborts them).
            let shutdown = h.stop();
            let finished =
                rt.block_on(async { tokio::time::timeout(STOP_WAIT, shutdown.wait()).await });
            if finished.is_err() {
                tracing::warn!(
                    "live view: a client did not close within {STOP_WAIT:?}; disconnected"
                );
            }
        }
        if let Some(p) = self.publisher.take()
            && join
        {
            let _ = p.join();
        }
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_background();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        // Never waits on the publisher: a tap may outlive a server dropped in a hurry.
        self.shut_down(false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(port: u16) -> LiveSettings {
        LiveSettings {
            address: "127.0.0.1".parse().expect("ip"),
            port,
            queue_messages: 64,
            band: None,
            sample_rate_hz: 100.0,
            epoch: Epoch { offset_ns: 0 },
            name: "test".into(),
        }
    }

    #[test]
    fn starts_on_a_free_port_and_stops_with_a_silent_client_connected() {
        let (server, tap) = LiveServer::start(&settings(0)).expect("start");
        let url = server.url().to_string();
        assert!(
            url.starts_with("ws://127.0.0.1:") && !url.ends_with(":0"),
            "{url}"
        );
        // A TCP client that never even finishes the WebSocket handshake.
        let addr = url.trim_start_matches("ws://");
        let _silent = std::net::TcpStream::connect(addr).expect("connect");
        drop(tap);
        // Returns (the test would hang otherwise).
        server.stop();
    }

    #[test]
    fn a_taken_port_is_a_bind_error_naming_the_address() {
        let (server, _tap) = LiveServer::start(&settings(0)).expect("start");
        let port: u16 = server
            .url()
            .rsplit(':')
            .next()
            .and_then(|p| p.parse().ok())
            .expect("port");
        match LiveServer::start(&settings(port)) {
            Err(e @ LiveError::Bind { .. }) => {
                assert!(e.to_string().contains(&format!("127.0.0.1:{port}")), "{e}")
            }
            other => panic!("expected a bind error, got {other:?}"),
        }
    }
}
