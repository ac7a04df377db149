//! The composition root of pulsetrack.
//!
//! `pulsetrackd` (the daemon) and `pulsetrack` (the command-line tool) are thin wrappers
//! around [`pulsetrackd_main`] and [`pulsetrack_main`], so that end-to-end tests can build
//! the very same programs under their own names.

pub mod backend;
pub mod cli;
pub mod console;
pub mod instance_lock;
pub mod live;
pub mod plot;
pub mod private_fs;
pub mod pulsetrackd;
pub mod recording;
pub mod rt;
pub mod runtime_paths;
pub mod service;
pub mod slot;
pub mod supervisor;

use std::process::ExitCode;

/// Entry point of the `pulsetrack` command-line tool.
pub fn pulsetrack_main() -> ExitCode {
    cli::run()
}

/// Entry point of the `pulsetrackd` daemon.
pub fn pulsetrackd_main() -> ExitCode {
    pulsetrackd::main()
}
