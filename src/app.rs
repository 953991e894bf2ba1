//! The program: parses arguments, sets up logging, dispatches to a subcommand, and turns the
//! result into an exit code.

use crate::{cli, node};

use clap::{Parser, Subcommand};
use log::LevelFilter;
use node::ros_args::{LogLevel, RosArgs};
use std::process::ExitCode;

/// The object orientation that minimises gripping power in a two-finger planar grasp.
#[derive(Debug, Parser)]
#[command(name = "grasp_orient", version, about, after_help = cli::EXIT_CODES)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Solve JSON-lines grasp candidates: one JSON recommendation per line.
    Solve(cli::solve::Args),
    /// Answer JSON-lines grasp candidates as one set, ranked by the force they need: a table, or
    /// the set's answer as JSON.
    Rank(cli::rank::Args),
    /// Plot the bounds and the gripping power of one candidate to SVG (like the paper's Fig. 9).
    Plot(cli::plot::Args),
    /// Run the ROS 2 node (ROS arguments follow --ros-args, as from ros2 run or launch).
    #[command(after_help = cli::node::parameters_help())]
    Node(cli::node::Args),
    /// Re-solve every candidate of MCAP recordings, with the settings they recorded, and
    /// compare with the recorded answers.
    #[command(after_help = cli::EXIT_CODES)]
    Replay(cli::replay::Args),
    /// Recover what a killed or damaged recording holds into a finished MCAP file: only what
    /// verifies, with what was dropped counted per topic.
    #[command(after_help = cli::EXIT_CODES)]
    Recover(cli::recover::Args),
    /// Republish the candidates of a recording to the live ROS graph, like ros2 bag play.
    Play(cli::play::Args),
}

/// What the libraries log without `RUST_LOG`: RustDDS warns about every unreachable locator; its
/// errors still show, and so do its warnings of input dropped by a resource bound (at most one
/// every 10 s per reader or bound). Everything else logs from `info` on.
const LIBRARY_LEVELS: [(&str, LevelFilter); 5] = [
    ("rustdds", LevelFilter::Error),
    (
        ros2_client::dds::rustdds::LIMITS_LOG_TARGET,
        LevelFilter::Warn,
    ),
    ("rustdds::network::udp_listener", LevelFilter::Off),
    ("ros2_client", LevelFilter::Warn),
    ("ros2_client::distributions", LevelFilter::Error),
];

/// Runs the command line `std::env::args` holds.
pub fn main() -> ExitCode {
    // Everything from --ros-args on belongs to ROS, not to clap.
    let argv: Vec<String> = std::env::args().collect();
    let split = argv
        .iter()
        .position(|a| a == "--ros-args")
        .unwrap_or(argv.len());
    let levels = match RosArgs::parse(&argv[split..]) {
        Ok(ros) => ros.log_levels,
        Err(e) => {
            eprintln!("grasp_orient: error: {e}");
            return ExitCode::from(2);
        }
    };
    init_logging(&levels);
    let cli = Cli::parse_from(&argv[..split]);
    let result = match &cli.command {
        Command::Solve(args) => cli::solve::run(args),
        Command::Rank(args) => cli::rank::run(args),
        Command::Plot(args) => cli::plot::run(args),
        Command::Node(args) => cli::node::run(args, &argv[split..]),
        Command::Replay(args) => cli::replay::run(args),
        Command::Recover(args) => cli::recover::run(args),
        Command::Play(args) => cli::play::run(args, &argv[split..]),
    };
    exit_code(result)
}

/// The one place where outcomes become exit codes, as `diff` and `cmp` use them: 0 success;
/// 1 the answer is no (`replay` found differences, `recover` lost messages); 2 trouble. clap
/// exits 2 on bad arguments before this. A reader that closed our standard output
/// (`grasp_orient solve | head`) is success.
fn exit_code(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<cli::Negative>().is_some() => {
            eprintln!("grasp_orient: {e:#}");
            ExitCode::from(1)
        }
        Err(e) => {
            eprintln!("grasp_orient: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Whether the error is a write to a pipe whose reader has gone.
fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The logger on stderr: `RUST_LOG` if set, else `info` with [`LIBRARY_LEVELS`]. Then
/// `--log-level LEVEL` sets the default level (and caps the libraries' at it: `fatal` silences
/// them too), and `--log-level NAME:=LEVEL` one logger's, whatever the order; `unset` changes
/// nothing.
fn init_logging(levels: &[(Option<String>, LogLevel)]) {
    let mut builder = env_logger::Builder::new();
    let from_env = std::env::var("RUST_LOG").ok();
    match &from_env {
        Some(filters) => {
            builder.parse_filters(filters);
        }
        None => {
            builder.filter_level(LevelFilter::Info);
            for (module, level) in LIBRARY_LEVELS {
                builder.filter_module(module, level);
            }
        }
    }
    let default = levels
        .iter()
        .filter(|(logger, _)| logger.is_none())
        .filter_map(|(_, level)| level.filter())
        .next_back();
    if let Some(default) = default {
        builder.filter_level(default);
        if from_env.is_none() {
            for (module, level) in LIBRARY_LEVELS {
                builder.filter_module(module, level.min(default));
            }
        }
    }
    for (logger, level) in levels {
        if let (Some(logger), Some(level)) = (logger, level.filter()) {
            builder.filter_module(logger, level);
        }
    }
    builder.target(env_logger::Target::Stderr).init();
}
