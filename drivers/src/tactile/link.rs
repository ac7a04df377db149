//! The serial task: open the port, handshake, decode frames, hand them to the control loop,
//! and on an unplug reopen the same stable path with backoff.

use std::sync::Arc;
use std::time::Duration;

use config::schema::SerialTactile;
use control::types::{ELEMENTS, TactileFrame};
use crossbeam_channel::{Receiver, Sender, TrySendError};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::watch;
use tokio_serial::{SerialPort, SerialStream};

use super::decoder::FrameDecoder;
use super::status::{LinkState, SharedStatus};
use super::stream_check::{Rejection, StreamCheck};
use super::wire::{Configure, DeviceInfo, Message, PROTOCOL_VERSION, WireError};
use crate::burst_log::BurstLog;
use crate::clock::Clock;

/// Configure messages sent without an answer before the connection is dropped and reopened.
const HANDSHAKE_ATTEMPTS: u32 = 3;

/// A burst of one kind of problem ends after this long without it, s.
const BURST_QUIET_S: f64 = 2.0;

/// Why a connection ended.
#[derive(Debug)]
enum SessionEnd {
    Stopped,
    Unplugged(String),
    HandshakeTimeout,
    Incompatible(String),
}

/// Everything the serial task owns.
pub(crate) struct Link {
    pub settings: SerialTactile,
    pub rate_hz: u16,
    pub clock: Arc<dyn Clock>,
    pub tx: Sender<TactileFrame>,
    /// A second handle on the queue, so that a full queue drops its oldest frame.
    pub drain: Receiver<TactileFrame>,
    pub status: SharedStatus,
    pub stop: watch::Receiver<()>,
}

/// Per-problem burst loggers.
struct Bursts {
    crc: BurstLog,
    framing: BurstLog,
    content: BurstLog,
    sequence: BurstLog,
    queue: BurstLog,
    open: BurstLog,
}

impl Bursts {
    fn new() -> Self {
        Self {
            crc: BurstLog::new("tactile: CRC errors", BURST_QUIET_S),
            framing: BurstLog::new("tactile: framing errors", BURST_QUIET_S),
            content: BurstLog::new("tactile: invalid frames", BURST_QUIET_S),
            sequence: BurstLog::new("tactile: lost or repeated frames", BURST_QUIET_S),
            queue: BurstLog::new(
                "tactile: consumer behind, oldest frames dropped",
                BURST_QUIET_S,
            ),
            open: BurstLog::new("tactile: cannot open the serial port", 30.0),
        }
    }

    fn end_quiet(&mut self, now_s: f64) {
        for b in [
            &mut self.crc,
            &mut self.framing,
            &mut self.content,
            &mut self.sequence,
            &mut self.queue,
        ] {
            b.end_if_quiet(now_s);
        }
    }
}

/// One open connection's state.
struct Session {
    decoder: FrameDecoder,
    handshaken: bool,
    configure_sent_s: f64,
    attempts: u32,
    last_frame_s: f64,
    stale: bool,
}

impl Link {
    pub async fn run(mut self) {
        let mut bursts = Bursts::new();
        // Kept across connections so that the consumer's sequence numbers never go back.
        let mut check = StreamCheck::new(self.settings.max_force_n);
        let mut backoff_s = self.settings.reconnect_initial_s;
        loop {
            self.status.update(|s| {
                if !matches!(s.state, LinkState::Incompatible(_)) {
                    s.state = LinkState::Opening;
                }
            });
            let builder = tokio_serial::new(&self.settings.path, self.settings.baud);
            let end = match SerialStream::open(&builder) {
                Ok(port) => {
                    if bursts.open.in_burst() {
                        tracing::info!("tactile: opened {}", self.settings.path);
                    }
                    bursts.open.end_if_quiet(f64::INFINITY);
                    check.restart();
                    self.session(port, &mut bursts, &mut check).await
                }
                Err(e) => {
                    let now = self.clock.now_s();
                    let path = self.settings.path.clone();
                    let msg = format!("cannot open {path}: {e}");
                    bursts.open.event(now, || {
                        format!("{msg}; is the array plugged in? retrying with backoff")
                    });
                    self.status.update(|s| {
                        s.stats.open_failures += 1;
                        s.last_problem = Some(msg);
                    });
                    SessionEnd::Unplugged(String::new())
                }
            };
            match end {
                SessionEnd::Stopped => return,
                SessionEnd::Unplugged(reason) if !reason.is_empty() => {
                    tracing::warn!(
                        "tactile: {} unplugged ({reason}); reconnecting",
                        self.settings.path
                    );
                    self.status.update(|s| {
                        s.stats.unplugs += 1;
                        s.last_problem = Some(format!("unplugged: {reason}"));
                    });
                    // A link that was working reconnects quickly the first time.
                    backoff_s = self.settings.reconnect_initial_s;
                }
                SessionEnd::Unplugged(_) => {}
                SessionEnd::HandshakeTimeout => {
                    let msg = format!(
                        "no answer to {HANDSHAKE_ATTEMPTS} configure messages on {}; \
                         is this the tactile array, at {} baud?",
                        self.settings.path, self.settings.baud
                    );
                    tracing::warn!("tactile: {msg}");
                    self.status.update(|s| {
                        s.stats.handshake_timeouts += 1;
                        s.last_problem = Some(msg);
                    });
                }
                SessionEnd::Incompatible(msg) => {
                    tracing::error!("tactile: {msg}");
                    self.status.update(|s| {
                        s.state = LinkState::Incompatible(msg.clone());
                        s.last_problem = Some(msg);
                    });
                    backoff_s = self.settings.reconnect_max_s;
                }
            }
            let sleep = tokio::time::sleep(Duration::from_secs_f64(backoff_s));
            tokio::select! {
                _ = self.stop.changed() => return,
                () = sleep => {}
            }
            backoff_s = (backoff_s * 2.0).min(self.settings.reconnect_max_s);
        }
    }

    async fn send_configure(&self, port: &mut SerialStream, streaming: bool) -> Result<(), String> {
        let m = Message::Configure(Configure {
            rate_hz: self.rate_hz,
            streaming,
        });
        port.write_all(&m.to_wire())
            .await
            .map_err(|e| format!("write failed: {e}"))
    }

    async fn session(
        &mut self,
        mut port: SerialStream,
        bursts: &mut Bursts,
        check: &mut StreamCheck,
    ) -> SessionEnd {
        // Whatever the device sent while nobody listened is old.
        let _ = port.clear(tokio_serial::ClearBuffer::Input);
        self.status.update(|s| {
            if !matches!(s.state, LinkState::Incompatible(_)) {
                s.state = LinkState::Handshaking;
            }
        });
        let now = self.clock.now_s();
        let mut sess = Session {
            decoder: FrameDecoder::new(),
            handshaken: false,
            configure_sent_s: now,
            attempts: 1,
            last_frame_s: now,
            stale: false,
        };
        if let Err(e) = self.send_configure(&mut port, true).await {
            return SessionEnd::Unplugged(e);
        }
        let tick_s = (self
            .settings
            .stale_after_s
            .min(self.settings.handshake_timeout_s)
            / 4.0)
            .clamp(0.001, 0.25);
        let tick = Duration::from_secs_f64(tick_s);
        let mut buf = [0u8; 512];
        let mut messages: Vec<Result<Message, WireError>> = Vec::with_capacity(32);
        loop {
            let read = tokio::select! {
                _ = self.stop.changed() => return SessionEnd::Stopped,
                r = tokio::time::timeout(tick, port.read(&mut buf)) => r,
            };
            let now = self.clock.now_s();
            match read {
                Err(_elapsed) => {}
                Ok(Ok(0)) => return SessionEnd::Unplugged("end of file".into()),
                Ok(Err(e)) => return SessionEnd::Unplugged(e.to_string()),
                Ok(Ok(n)) => {
                    self.status.update(|s| s.stats.bytes += n as u64);
                    messages.clear();
                    sess.decoder.push(&buf[..n], |m| messages.push(m));
                    for m in messages.drain(..) {
                        if let Err(end) = self
                            .handle(m, now, &mut sess, check, bursts, &mut port)
                            .await
                        {
                            return end;
                        }
                    }
                }
            }
            bursts.end_quiet(now);
            // Timers.
            if !sess.handshaken {
                if now - sess.configure_sent_s > self.settings.handshake_timeout_s {
                    if sess.attempts >= HANDSHAKE_ATTEMPTS {
                        return SessionEnd::HandshakeTimeout;
                    }
                    sess.attempts += 1;
                    sess.configure_sent_s = now;
                    if let Err(e) = self.send_configure(&mut port, true).await {
                        return SessionEnd::Unplugged(e);
                    }
                }
            } else if now - sess.last_frame_s > self.settings.stale_after_s {
                if !sess.stale {
                    sess.stale = true;
                    let age = now - sess.last_frame_s;
                    tracing::warn!(
                        "tactile: stream stale, no valid frame for {age:.3} s; asking the device to stream"
                    );
                    self.status.update(|s| {
                        s.state = LinkState::Stale;
                        s.stats.stale_events += 1;
                        s.last_problem = Some(format!("stream stale ({age:.3} s without a frame)"));
                    });
                }
                if now - sess.configure_sent_s > self.settings.handshake_timeout_s {
                    sess.configure_sent_s = now;
                    if let Err(e) = self.send_configure(&mut port, true).await {
                        return SessionEnd::Unplugged(e);
                    }
                }
            }
        }
    }

    async fn handle(
        &mut self,
        m: Result<Message, WireError>,
        now: f64,
        sess: &mut Session,
        check: &mut StreamCheck,
        bursts: &mut Bursts,
        port: &mut SerialStream,
    ) -> Result<(), SessionEnd> {
        match m {
            Err(e @ WireError::BadCrc { .. }) => {
                bursts.crc.event(now, || e.to_string());
                self.status.update(|s| s.stats.crc_errors += 1);
            }
            Err(e @ WireError::UnknownType(_)) => {
                bursts.framing.event(now, || e.to_string());
                self.status.update(|s| s.stats.unexpected_messages += 1);
            }
            Err(e) => {
                bursts.framing.event(now, || e.to_string());
                self.status.update(|s| s.stats.framing_errors += 1);
            }
            Ok(Message::Configure(_)) => {
                bursts
                    .framing
                    .event(now, || "a configure message from the device".into());
                self.status.update(|s| s.stats.unexpected_messages += 1);
            }
            Ok(Message::DeviceInfo(info)) => {
                self.check_device(&info).map_err(SessionEnd::Incompatible)?;
                if sess.handshaken {
                    tracing::info!("tactile: device announced itself again (restarted?)");
                } else {
                    tracing::info!(
                        "tactile: {} ready: firmware {}.{}.{}, serial {}, {} channels at {} Hz",
                        self.settings.path,
                        info.firmware[0],
                        info.firmware[1],
                        info.firmware[2],
                        info.serial_number,
                        info.channels,
                        info.rate_hz
                    );
                }
                // Our own configure messages are answered too, so this is not proof of a
                // restart; but if the sequence steps back next, follow it.
                check.expect_restart();
                sess.handshaken = true;
                sess.last_frame_s = now;
                self.status.update(|s| {
                    s.stats.handshakes += 1;
                    s.device = Some(info);
                    s.state = LinkState::Streaming;
                });
                if info.rate_hz == 0 {
                    // Announced after a restart, not streaming: ask again.
                    sess.configure_sent_s = now;
                    self.send_configure(port, true)
                        .await
                        .map_err(SessionEnd::Unplugged)?;
                }
            }
            Ok(Message::Forces(f)) => {
                if !sess.handshaken {
                    self.status.update(|s| s.stats.before_handshake += 1);
                    return Ok(());
                }
                let checked = check.accept(&f, now);
                if checked.missing > 0 {
                    bursts.sequence.event(now, || {
                        format!("{} frames missing before frame {}", checked.missing, f.seq)
                    });
                }
                self.status.update(|s| {
                    if checked.missing > 0 {
                        s.stats.gaps += 1;
                        s.stats.missing_frames += checked.missing;
                    }
                    s.stats.resyncs += u64::from(checked.resynced);
                });
                match checked.frame {
                    Ok(frame) => {
                        sess.last_frame_s = now;
                        let dropped = self.deliver(frame);
                        if dropped {
                            bursts.queue.event(now, || "queue full".into());
                        }
                        let was_stale = sess.stale;
                        sess.stale = false;
                        self.status.update(|s| {
                            s.stats.frames += 1;
                            s.stats.queue_drops += u64::from(dropped);
                            if was_stale {
                                s.state = LinkState::Streaming;
                            }
                        });
                        if was_stale {
                            tracing::info!("tactile: stream fresh again");
                        }
                    }
                    Err(r) => {
                        match r {
                            Rejection::Duplicate { .. } | Rejection::Reordered { .. } => {
                                bursts.sequence.event(now, || r.to_string())
                            }
                            _ => bursts.content.event(now, || r.to_string()),
                        };
                        self.status.update(|s| match r {
                            Rejection::Duplicate { .. } => s.stats.duplicates += 1,
                            Rejection::Reordered { .. } => s.stats.reordered += 1,
                            Rejection::WrongChannelCount { .. } => s.stats.wrong_channel_count += 1,
                            Rejection::ElementFault { .. } => s.stats.element_faults += 1,
                            Rejection::OutOfRange { .. } => s.stats.out_of_range += 1,
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Hand a frame over; when the queue is full drop its oldest frame. Returns whether one
    /// was dropped. Never waits.
    fn deliver(&self, frame: TactileFrame) -> bool {
        match self.tx.try_send(frame) {
            Ok(()) => false,
            Err(TrySendError::Full(frame)) => {
                let _ = self.drain.try_recv();
                let _ = self.tx.try_send(frame);
                true
            }
            Err(TrySendError::Disconnected(_)) => false,
        }
    }

    fn check_device(&self, info: &DeviceInfo) -> Result<(), String> {
        if info.protocol_version != PROTOCOL_VERSION {
            return Err(format!(
                "device speaks protocol version {}, this build speaks {PROTOCOL_VERSION}; \
                 update the firmware or pulsetrack",
                info.protocol_version
            ));
        }
        if usize::from(info.channels) != ELEMENTS {
            return Err(format!(
                "device has {} channels, the array needs {ELEMENTS}; wrong device on {}?",
                info.channels, self.settings.path
            ));
        }
        if info.rate_hz != 0 && info.rate_hz != self.rate_hz {
            return Err(format!(
                "device streams at {} Hz but sensor.sample_rate_hz asks for {} Hz; \
                 the firmware does not support that rate",
                info.rate_hz, self.rate_hz
            ));
        }
        Ok(())
    }
}
