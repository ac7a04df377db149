//! `pulsetrack`: console verbs for the daemon, and offline sim / bench / fem / check-config.

fn main() -> std::process::ExitCode {
    pulsetrack_daemon::pulsetrack_main()
}
