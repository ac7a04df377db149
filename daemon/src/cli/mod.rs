//! The `pulsetrack` command line: one module per subcommand.

mod bench;
mod check_config;
mod fem;
mod sim;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "pulsetrack",
    version,
    about = "Tactile artery tracking: console, simulator and tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Check a configuration or scene file and report every problem with file, line and field.
    CheckConfig(check_config::Args),
    /// Run the tissue FEM: the seed papers' studies or one model file.
    Fem(fem::Args),
    /// Run whole trials on the simulated bench in lockstep and report the tracking error.
    Sim(sim::Args),
    /// Monte Carlo of trials over scenes and trackers on every core: speed against error.
    Bench(bench::Args),
}

pub fn run() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::CheckConfig(args) => check_config::run(&args),
        Command::Fem(args) => fem::run(&args),
        Command::Sim(args) => sim::run(&args),
        Command::Bench(args) => bench::run(&args),
    }
}
