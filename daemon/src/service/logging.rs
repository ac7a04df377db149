//! Logs through tracing: to the journal when systemd connected our stderr to it (it sets
//! JOURNAL_STREAM), to stderr otherwise. `RUST_LOG` filters those as usual; the default is
//! info. Lines at info and above also go to the trial's `/log` ([`super::log_forward`]),
//! whatever `RUST_LOG` says (filtered
//! per layer, so debug call sites stay disabled unless `RUST_LOG` asks for them).

use tracing_subscriber::EnvFilter;
use tracing_subscriber::filter::LevelFilter;
use tracing_subscriber::prelude::*;

use super::log_forward::ForwardLayer;

/// Where the log went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogSink {
    Journald,
    Stderr,
}

/// Install the global subscriber once; later calls (in-process daemons in tests and the
/// demo) keep the first.
pub fn init(default_level: &str) -> LogSink {
    let filter =
        || EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default_level));
    if std::env::var_os("JOURNAL_STREAM").is_some()
        && let Ok(layer) = tracing_journald::layer()
    {
        let _ = tracing_subscriber::registry()
            .with(layer.with_filter(filter()))
            .with(ForwardLayer.with_filter(LevelFilter::INFO))
            .try_init();
        return LogSink::Journald;
    }
    let _ = tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(std::io::stderr)
                .with_filter(filter()),
        )
        .with(ForwardLayer.with_filter(LevelFilter::INFO))
        .try_init();
    LogSink::Stderr
}
