//! The real `pulsetrackd` program under a test name, so `cargo test` builds it for the
//! end-to-end tests (a package cannot see another package's binaries).

fn main() -> std::process::ExitCode {
    daemon::pulsetrackd_main()
}
