//! `pulsetrack recover FILE...`: rewrite trial recordings cut short (kill -9, a crash, a power
//! cut) as complete, indexed MCAP files that Foxglove and PlotJuggler open; the original is
//! kept as `NAME.truncated.mcap`. Complete files are left alone.

use crate::cli::failure::{self, Failure};
use crate::cli::stdout::outln;

use std::path::PathBuf;
use std::process::ExitCode;

use crate::recording::recover::recover_in_place;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Trial recordings (`.mcap`).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Print one JSON line per file: `{"file":...,"recovered_messages":N}` (null when the
    /// file was complete); a file that cannot be recovered is a JSON error on stderr.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> ExitCode {
    let mut failed = false;
    for f in &args.files {
        match recover_in_place(f) {
            Ok(n) if args.json => outln!(
                "{}",
                serde_json::json!({"file": f.display().to_string(), "recovered_messages": n})
            ),
            Ok(Some(n)) => outln!("{}: recovered {n} messages", f.display()),
            Ok(None) => outln!("{}: complete; nothing to do", f.display()),
            Err(e) if args.json => {
                eprintln!(
                    "{}",
                    failure::json_line("recover", Failure::Failed, &e.to_string())
                );
                failed = true;
            }
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
