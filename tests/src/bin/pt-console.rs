//! The real `pulsetrack` program under a test name, for the end-to-end tests.

fn main() -> std::process::ExitCode {
    daemon::pulsetrack_main()
}
