//! The `pulsetrack` command line: one module per subcommand.

mod bench;
mod bench_search;
mod bound;
mod calibrate;
mod check_config;
mod completions;
pub mod console;
mod console_flow;
pub mod daemon_config;
mod demo;
mod failure;
mod fem;
mod lengths;
mod man;
mod progress;
mod recover;
mod replay;
mod search;
mod sim;
mod stdout;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use failure::Failure;

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
    /// Run a step of a rig calibration procedure on the daemon and print its result
    /// (docs/rig-bring-up.md).
    Calibrate(calibrate::CalibrateArgs),
    /// Find the artery in a region of the tissue surface without being shown, and with
    /// --then-track follow it (docs/search.md).
    Search(search::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(completions::Args),
    /// Print the man page, or write one page per subcommand into a directory.
    Man(man::Args),
}

/// A command line clap refused: help and version as clap prints them, anything else as a
/// usage error (exit 2), in JSON when `--json` was among the arguments.
fn usage_error(e: &clap::Error, command: &str, json: bool) -> ExitCode {
    use clap::error::ErrorKind;
    if !json
        || matches!(
            e.kind(),
            ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
        )
    {
        // Prints to stdout or stderr as fits the kind; a closed pipe is not worth a panic.
        let _ = e.print();
        return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
    }
    let reason = e.render().to_string();
    failure::report(command, true, Failure::Usage, reason.trim_end())
}

/// The whole command tree, for completions, man pages and tests.
pub(crate) fn command() -> clap::Command {
    use clap::CommandFactory;
    Cli::command()
}

pub fn run() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let args: Vec<String> = std::env::args().skip(1).collect();
            let command = args
                .iter()
                .find(|a| !a.starts_with('-'))
                .map_or("", String::as_str);
            return usage_error(&e, command, args.iter().any(|a| a == "--json"));
        }
    };
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
        Command::Calibrate(args) => calibrate::run(&args),
        Command::Search(args) => search::run(&args),
        Command::Completions(args) => completions::run(&args),
        Command::Man(args) => man::run(&args),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Every subcommand and every argument, at any depth, with its path, lacking help.
    fn without_help(cmd: &clap::Command, path: &str, missing: &mut Vec<String>) {
        for arg in cmd.get_arguments() {
            let id = arg.get_id().as_str();
            if id == "help" || id == "version" {
                continue;
            }
            if arg.get_help().is_none() && arg.get_long_help().is_none() {
                missing.push(match arg.get_long() {
                    Some(long) => format!("{path} --{long}"),
                    None => format!("{path} <{id}>"),
                });
            }
        }
        for sub in cmd.get_subcommands() {
            let sub_path = format!("{path} {}", sub.get_name());
            if sub.get_name() != "help" && sub.get_about().is_none() {
                missing.push(sub_path.clone());
            }
            without_help(sub, &sub_path, missing);
        }
    }

    #[test]
    fn every_subcommand_and_flag_has_help() {
        let cmd = Cli::command();
        cmd.clone().debug_assert();
        let mut missing = Vec::new();
        without_help(&cmd, "pulsetrack", &mut missing);
        assert!(
            missing.is_empty(),
            "no help text for: {}",
            missing.join(", ")
        );
        assert!(cmd.get_subcommands().count() > 10, "the walk saw the tree");
        // The walk finds a bare flag, positional and subcommand at depth.
        let bare = clap::Command::new("t").subcommand(
            clap::Command::new("a")
                .about("has help")
                .arg(clap::Arg::new("x").long("x-mm"))
                .arg(clap::Arg::new("file"))
                .subcommand(clap::Command::new("b")),
        );
        let mut found = Vec::new();
        without_help(&bare, "t", &mut found);
        assert_eq!(found, ["t a --x-mm", "t a <file>", "t a b"]);
    }
}
