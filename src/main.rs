//! `grasp_orient`: parses arguments, sets up logging, dispatches, and turns the result into an
//! exit code.

use clap::{Parser, Subcommand};
use grasp_orient::cli;
use std::process::ExitCode;

/// The object orientation that minimises gripping power in a two-finger planar grasp.
#[derive(Debug, Parser)]
#[command(name = "grasp_orient", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Solve JSON-lines grasp candidates: one JSON recommendation per line.
    Solve(cli::solve::Args),
    /// Plot the bounds and the gripping power of one candidate to SVG (like the paper's Fig. 9).
    Plot(cli::plot::Args),
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .target(env_logger::Target::Stderr)
        .init();
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Solve(args) => cli::solve::run(args),
        Command::Plot(args) => cli::plot::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("grasp_orient: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
