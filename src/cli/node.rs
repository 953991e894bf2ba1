//! `grasp_orient node [--demo] [--echo] [--ros-args ...]`: the ROS 2 node.

use crate::config::render;
use crate::node::{self, Options};

/// Arguments of `node` (ROS arguments come separately, after `--ros-args`).
#[derive(Debug, Clone, Default, clap::Args)]
pub(crate) struct Args {
    /// Also send the paper's four case studies to the node over DDS, print the answers, and exit.
    #[arg(long)]
    pub(crate) demo: bool,
    /// Benchmark floor: answer every candidate with an empty recommendation (same header and id)
    /// without solving.
    #[arg(long)]
    pub(crate) echo: bool,
}

/// The parameters, for `node --help`.
pub(crate) fn parameters_help() -> String {
    render::help()
}

/// Runs the node until Ctrl-C or SIGTERM (or until the demo is done).
pub(crate) fn run(args: &Args, ros_argv: &[String]) -> anyhow::Result<()> {
    node::run(
        Options {
            demo: args.demo,
            echo: args.echo,
        },
        ros_argv,
    )
}
