//! The recorder thread: the one place that writes trial files and then tells the world.
//!
//! Everything the daemon says to console clients (replies and stream events) passes through
//! here in order, after the records it concerns: a reply or event marked durable goes out
//! only once its records are fdatasync'd, so nothing acknowledged is lost to a crash, a
//! kill -9 or a power cut. Other records reach the kernel every `flush_interval_s` and the
//! disk every `fsync_interval_s`.
//!
//! A recording that cannot be written (a full disk, a read-only or vanished folder) is never
//! dropped quietly: the recorder tells the supervisor at once (which stops the trial safely
//! and latches `recording_failed`), every durable reply for that trial becomes a
//! `recording_failed` error naming the file and the OS error, and durable events for it are
//! withheld (counted in the log) rather than published as if recorded.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError};
use serde_json::Value;

use crate::console::hub::{Responder, StreamEvent, StreamHub};
use crate::console::protocol::{ErrorCode, error_reply};
use crate::recording::provenance::MetadataRecord;
use crate::recording::topics::Topic;
use crate::recording::trial_file::TrialFile;

pub enum RecorderMsg {
    /// Start a trial file `<dir>/<id>.mcap`.
    Open {
        id: String,
        /// Named metadata records written at the start of the file.
        metadata: Vec<MetadataRecord>,
        /// Daemon time `t_s` is Unix time `epoch_offset_ns + t_s * 1e9` ns in this file.
        epoch_offset_ns: i128,
    },
    /// A metadata record for the open trial (a label given when tracking starts).
    Metadata { record: MetadataRecord },
    /// A record for the open trial (dropped when none is open).
    Write {
        topic: Topic,
        t_s: f64,
        json: Vec<u8>,
    },
    /// Send a stream event to subscribers.
    Publish {
        event: Arc<StreamEvent>,
        durable: bool,
    },
    /// Answer a console request.
    Reply {
        to: Responder,
        reply: Value,
        durable: bool,
    },
    /// Finish the open trial: footer, summary JSON beside it, then publish `then`.
    Close {
        summary: Value,
        then: Option<Arc<StreamEvent>>,
    },
    /// Close everything and stop.
    Shutdown { done: crossbeam_channel::Sender<()> },
}

impl std::fmt::Debug for RecorderMsg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self {
            RecorderMsg::Open { .. } => "Open",
            RecorderMsg::Metadata { .. } => "Metadata",
            RecorderMsg::Write { .. } => "Write",
            RecorderMsg::Publish { .. } => "Publish",
            RecorderMsg::Reply { .. } => "Reply",
            RecorderMsg::Close { .. } => "Close",
            RecorderMsg::Shutdown { .. } => "Shutdown",
        };
        f.write_str(name)
    }
}

#[derive(Debug, Clone)]
pub struct RecorderSettings {
    pub dir: PathBuf,
    pub flush_interval: Duration,
    pub fsync_interval: Duration,
}

/// A trial recording that could not be written: which file, and the OS's words.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingFailure {
    pub path: PathBuf,
    pub error: String,
}

impl RecordingFailure {
    pub fn describe(&self) -> String {
        format!("cannot write {}: {}", self.path.display(), self.error)
    }
}

/// Told to whoever must stop the trial when its recording fails.
pub type FailureAlert = Box<dyn Fn(RecordingFailure) + Send>;

pub struct Recorder {
    settings: RecorderSettings,
    hub: StreamHub,
    file: Option<TrialFile>,
    trial_id: Option<String>,
    last_flush: Instant,
    last_sync: Instant,
    /// Set when the open trial's file failed; cleared when the trial closes.
    failure: Option<RecordingFailure>,
    alert: Option<FailureAlert>,
    withheld_events: u64,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("trial", &self.trial_id)
            .finish()
    }
}

impl Recorder {
    pub fn new(settings: RecorderSettings, hub: StreamHub) -> Self {
        Self {
            settings,
            hub,
            file: None,
            trial_id: None,
            last_flush: Instant::now(),
            last_sync: Instant::now(),
            failure: None,
            alert: None,
            withheld_events: 0,
        }
    }

    /// Call `alert` (once per trial) when the open trial's recording fails.
    pub fn on_failure(mut self, alert: FailureAlert) -> Self {
        self.alert = Some(alert);
        self
    }

    /// Run until `Shutdown` (or every sender is gone).
    pub fn run(mut self, inbox: Receiver<RecorderMsg>) {
        loop {
            match inbox.recv_timeout(self.settings.flush_interval) {
                Ok(RecorderMsg::Shutdown { done }) => {
                    self.close_file(None);
                    let _ = done.send(());
                    return;
                }
                Ok(msg) => self.handle(msg),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => {
                    self.close_file(None);
                    return;
                }
            }
            self.periodic();
        }
    }

    fn handle(&mut self, msg: RecorderMsg) {
        match msg {
            RecorderMsg::Open {
                id,
                metadata,
                epoch_offset_ns,
            } => self.open(id, &metadata, epoch_offset_ns),
            RecorderMsg::Metadata { record } => {
                if let Some(f) = self.file.as_mut()
                    && let Err(e) = f.write_metadata(&record)
                {
                    self.fail(&e);
                }
            }
            RecorderMsg::Write { topic, t_s, json } => {
                if let Some(f) = self.file.as_mut()
                    && let Err(e) = f.write(topic, t_s, &json)
                {
                    self.fail(&e);
                }
            }
            RecorderMsg::Publish { event, durable } => {
                if durable {
                    self.sync();
                    if self.failure.is_some() {
                        self.withheld_events += 1;
                        return;
                    }
                }
                self.hub.publish(event);
            }
            RecorderMsg::Reply { to, reply, durable } => {
                if durable {
                    self.sync();
                }
                let reply = match (&self.failure, durable) {
                    (Some(f), true) => not_recorded(&reply, f),
                    _ => reply,
                };
                to.send(reply);
            }
            RecorderMsg::Close { summary, then } => {
                self.close_file(Some(summary));
                if let Some(e) = then {
                    self.hub.publish(e);
                }
            }
            RecorderMsg::Shutdown { .. } => {}
        }
    }

    fn open(&mut self, id: String, metadata: &[MetadataRecord], epoch_offset_ns: i128) {
        self.close_file(None);
        let path = self.settings.dir.join(format!("{id}.mcap"));
        self.trial_id = Some(id);
        if let Err(e) = crate::private_fs::ensure_private_dir(&self.settings.dir) {
            return self.set_failure(RecordingFailure {
                path: self.settings.dir.clone(),
                error: e,
            });
        }
        match TrialFile::create(&path, metadata, epoch_offset_ns) {
            Ok(f) => {
                tracing::info!("recording trial to {}", path.display());
                self.file = Some(f);
            }
            Err(e) => self.set_failure(RecordingFailure {
                path,
                error: e.to_string(),
            }),
        }
    }

    fn fail(&mut self, e: &std::io::Error) {
        let path = self
            .file
            .as_ref()
            .map(|f| f.path().to_path_buf())
            .unwrap_or_else(|| self.settings.dir.clone());
        // The writer is forgotten, not finished: finishing would only try to write more to
        // a file that just refused, and what reached the disk stays recoverable.
        if let Some(f) = self.file.take() {
            f.abandon();
        }
        self.set_failure(RecordingFailure {
            path,
            error: e.to_string(),
        });
    }

    fn set_failure(&mut self, failure: RecordingFailure) {
        if self.failure.is_some() {
            return;
        }
        tracing::error!(
            "recording failed: {}; stopping the trial",
            failure.describe()
        );
        if let Some(alert) = &self.alert {
            alert(failure.clone());
        }
        self.failure = Some(failure);
    }

    fn sync(&mut self) {
        if let Some(f) = self.file.as_mut() {
            match f.sync() {
                Ok(()) => {
                    self.last_flush = Instant::now();
                    self.last_sync = self.last_flush;
                }
                Err(e) => self.fail(&e),
            }
        }
    }

    fn periodic(&mut self) {
        let now = Instant::now();
        if now.duration_since(self.last_sync) >= self.settings.fsync_interval {
            self.sync();
        } else if now.duration_since(self.last_flush) >= self.settings.flush_interval {
            if let Some(f) = self.file.as_mut()
                && let Err(e) = f.flush()
            {
                self.fail(&e);
            }
            self.last_flush = now;
        }
    }

    fn close_file(&mut self, summary: Option<Value>) {
        let id = self.trial_id.take();
        if let Some(f) = self.file.take() {
            let path = f.path().to_path_buf();
            match f.finish() {
                Ok(n) => {
                    tracing::info!("trial recording closed: {} ({n} messages)", path.display())
                }
                Err(e) => tracing::error!(
                    "closing {}: {e}; the file stays readable up to its last flush (`pulsetrack recover`)",
                    path.display()
                ),
            }
        }
        if let Some(f) = self.failure.take()
            && self.withheld_events > 0
        {
            tracing::error!(
                "{} events of the failed trial were not published because they could not be recorded ({})",
                self.withheld_events,
                f.describe()
            );
        }
        self.withheld_events = 0;
        if let (Some(id), Some(summary)) = (id, summary) {
            let path = self.settings.dir.join(format!("{id}.json"));
            if let Err(e) = write_json_atomically(&path, &summary) {
                tracing::error!("writing the trial summary {}: {e}", path.display());
            }
        }
    }
}

/// A durable reply that cannot keep its promise becomes an error saying why.
fn not_recorded(reply: &Value, f: &RecordingFailure) -> Value {
    let id = reply.get("id").and_then(Value::as_u64);
    let mut r = error_reply(
        id,
        ErrorCode::RecordingFailed,
        &format!(
            "not recorded: {}; the trial is stopped (free space or fix the folder, then reset)",
            f.describe()
        ),
    );
    if let (Value::Object(o), Some(state)) = (&mut r, reply.get("state")) {
        o.insert("state".into(), state.clone());
    }
    r
}

/// Write `value` to `path` through a temporary file, fsync'd and renamed into place.
pub fn write_json_atomically(path: &Path, value: &Value) -> std::io::Result<()> {
    use std::io::Write;
    let tmp = path.with_extension("json.tmp");
    // A stale temporary (or anything planted there) goes; the new one is made afresh.
    match std::fs::remove_file(&tmp) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e),
    }
    {
        let mut f = crate::private_fs::create_new(&tmp)?;
        serde_json::to_writer_pretty(&mut f, value)?;
        f.write_all(b"\n")?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)?;
    if let Some(dir) = path.parent()
        && let Ok(d) = std::fs::File::open(dir)
    {
        let _ = d.sync_all();
    }
    Ok(())
}
