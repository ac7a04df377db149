//! `pulsetrackd`: the tracking daemon.

fn main() -> std::process::ExitCode {
    pulsetrack_daemon::pulsetrackd_main()
}
