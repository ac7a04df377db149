//! `pulsetrack recover FILE...`: rewrite trial recordings cut short (kill -9, a crash, a power
//! cut) as complete, indexed MCAP files that Foxglove and PlotJuggler open; the original is
//! kept as `NAME.truncated.mcap`. Complete files are left alone.

use crate::cli::stdout::outln;

use std::path::PathBuf;
use std::process::ExitCode;

use crate::recording::recover::recover_in_place;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Trial recordings (`.mcap`).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
}

pub fn run(args: &Args) -> ExitCode {
    let mut failed = false;
    for f in &args.files {
        match recover_in_place(f) {
            Ok(Some(n)) => outln!("{}: recovered {n} messages", f.display()),
            Ok(None) => outln!("{}: complete; nothing to do", f.display()),
            Err(e) => {
                eprintln!("{e}");
                failed = true;
            }
        }
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
