//! The daemon's own log lines (its `tracing` events at info and above, from any thread:
//! drivers, the recorder, the live view's server) onto the trial's `/log` channel, in the
//! recording and the live view, beside the lines the supervisor writes there itself.
//!
//! A tracing layer hands each line to the supervisor through a bounded queue that drops and
//! counts rather than blocks, since a log call on the 1 kHz loop must never wait; the
//! supervisor stamps it on its clock and emits it as every other `/log` line. Lines the
//! supervisor already put on `/log` are traced under [`ALREADY_ON_LOG`] and not forwarded
//! again.

use std::fmt::Write as _;
use std::sync::RwLock;
use std::sync::atomic::{AtomicU64, Ordering};

use crossbeam_channel::{Receiver, Sender};
use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, Layer};

use crate::recording::foxglove_msgs::level;

/// The tracing target of lines the supervisor writes to `/log` itself as well.
pub const ALREADY_ON_LOG: &str = "pulsetrackd::log";

/// A log line on its way to `/log`.
#[derive(Debug, Clone, PartialEq)]
pub struct ForwardedLine {
    /// foxglove.Log level: 2 info, 3 warning, 4 error.
    pub level: u8,
    /// The tracing target (the module that logged it).
    pub target: String,
    pub message: String,
    pub file: String,
    pub line: u32,
}

/// The supervisor that receives the lines; the newest one to connect (one per daemon).
static SINK: RwLock<Option<Sender<ForwardedLine>>> = RwLock::new(None);
static DROPPED: AtomicU64 = AtomicU64::new(0);

/// Route log lines to a new queue of `capacity` lines and return its receiving end.
pub fn connect(capacity: usize) -> Receiver<ForwardedLine> {
    let (tx, rx) = crossbeam_channel::bounded(capacity.max(1));
    if let Ok(mut sink) = SINK.write() {
        *sink = Some(tx);
    }
    rx
}

/// Lines dropped so far because the queue was full (lines logged while no daemon runs in
/// the process are not counted).
pub fn dropped() -> u64 {
    DROPPED.load(Ordering::Relaxed)
}

/// The layer `logging::init` installs.
#[derive(Debug, Default, Clone, Copy)]
pub struct ForwardLayer;

impl<S: Subscriber> Layer<S> for ForwardLayer {
    fn on_event(&self, event: &Event<'_>, _ctx: Context<'_, S>) {
        let meta = event.metadata();
        if meta.target() == ALREADY_ON_LOG || *meta.level() > Level::INFO {
            return;
        }
        // `try_read`: a writer (a daemon starting) never makes a log call wait.
        let Ok(sink) = SINK.try_read() else {
            DROPPED.fetch_add(1, Ordering::Relaxed);
            return;
        };
        let Some(tx) = sink.as_ref() else {
            return;
        };
        let mut text = Text::default();
        event.record(&mut text);
        let line = ForwardedLine {
            level: match *meta.level() {
                Level::ERROR => level::ERROR,
                Level::WARN => level::WARNING,
                _ => level::INFO,
            },
            target: meta.target().to_string(),
            message: text.0,
            file: meta.file().unwrap_or_default().to_string(),
            line: meta.line().unwrap_or(0),
        };
        // A daemon that has stopped (in-process tests, the demo) is not a loss to count.
        if let Err(crossbeam_channel::TrySendError::Full(_)) = tx.try_send(line) {
            DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The event's message, then its other fields as `name=value`.
#[derive(Default)]
struct Text(String);

impl Visit for Text {
    fn record_str(&mut self, field: &Field, value: &str) {
        self.push(field, format_args!("{value}"));
    }

    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        self.push(field, format_args!("{value:?}"));
    }
}

impl Text {
    fn push(&mut self, field: &Field, value: std::fmt::Arguments<'_>) {
        let sep = if self.0.is_empty() { "" } else { " " };
        let _ = if field.name() == "message" {
            write!(self.0, "{sep}{value}")
        } else {
            write!(self.0, "{sep}{}={value}", field.name())
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tracing_subscriber::prelude::*;

    #[test]
    fn info_and_above_are_forwarded_with_their_fields_and_a_full_queue_drops() {
        let subscriber = tracing_subscriber::registry().with(ForwardLayer);
        tracing::subscriber::with_default(subscriber, || {
            let rx = connect(2);
            let before = dropped();
            tracing::debug!("not forwarded");
            tracing::info!(port = 8765, "live view on");
            tracing::warn!(target: ALREADY_ON_LOG, "the supervisor has this one");
            tracing::error!("the CAN adapter is gone");
            tracing::warn!("one too many");
            let lines: Vec<ForwardedLine> = rx.try_iter().collect();
            assert_eq!(lines.len(), 2, "{lines:?}");
            assert_eq!(lines[0].level, level::INFO);
            assert_eq!(lines[0].message, "live view on port=8765");
            assert!(lines[0].file.ends_with("log_forward.rs") && lines[0].line > 0);
            assert_eq!(lines[1].level, level::ERROR);
            assert_eq!(lines[1].message, "the CAN adapter is gone");
            assert_eq!(dropped() - before, 1);
        });
    }
}
