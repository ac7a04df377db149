//! `pulsetrack check-config FILE`: load and validate a file, print every problem.

use crate::cli::stdout::outln;

use std::path::PathBuf;
use std::process::ExitCode;

use config::{Config, load_file};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The RON file to check.
    pub file: PathBuf,
}

pub fn run(args: &Args) -> ExitCode {
    match load_file::<Config>(&args.file) {
        Ok(loaded) => {
            outln!(
                "{}: ok (config version {})",
                loaded.origin,
                loaded.value.version
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
