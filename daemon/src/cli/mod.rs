//! The `pulsetrack` command line: one module per subcommand.

mod bench;
mod bound;
mod check_config;
pub mod console;
mod demo;
mod fem;
mod lengths;
mod recover;
mod replay;
mod sim;
mod stdout;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(
    name = "pulsetrack",
    version,
    about = "Tactile artery tracking: console, simulator and tools"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Debug, Subcommand)]
pub(crate) enum Command {
    /// Check a daemon configuration, scene or FEM model file and what it refers to; report
    /// every problem with file, line and field.
    CheckConfig(check_config::Args),
    /// Run a whole seeded tracking trial on the simulator through the real daemon and
    /// console; print the summary and write plots.
    Demo(demo::Args),
    #[command(flatten)]
    Console(console::Verb),
    /// Run the tissue FEM: the seed papers' studies or one model file.
    Fem(fem::Args),
    /// Rewrite trial recordings cut short (kill -9, crash) as complete MCAP files.
    Recover(recover::Args),
    /// Feed a recorded trial's frames and tracker calls to a tracker offline and print the
    /// points it locates, against those recorded (bit for bit with the recording's tracker).
    Replay(replay::Args),
    /// Run whole trials on the simulated bench in lockstep and report the tracking error.
    Sim(sim::Args),
    /// The weakest pulse a scene lets an ideal detector feel: beats to decide, and the
    /// position bound after them.
    Bound(bound::Args),
    /// Monte Carlo of trials over scenes and trackers on every core: speed against error.
    Bench(bench::Args),
}

pub fn run() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::CheckConfig(args) => check_config::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Console(verb) => console::run(&verb),
        Command::Fem(args) => fem::run(&args),
        Command::Recover(args) => recover::run(&args),
        Command::Replay(args) => replay::run(&args),
        Command::Sim(args) => sim::run(&args),
        Command::Bound(args) => bound::run(&args),
        Command::Bench(args) => bench::run(&args),
    }
}
