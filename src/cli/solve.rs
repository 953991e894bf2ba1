//! `grasp_orient solve [FILE]`: JSON lines in, one JSON line out per candidate.

use super::SolveOptions;
use crate::geometry::ClosingAxis;
use crate::jsonl::answer_lines;
use anyhow::Context;
use std::io::BufReader;
use std::path::PathBuf;

/// Arguments of `solve`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Args {
    /// File of JSON lines, one GraspCandidate per line (fields as in msg/GraspCandidate.msg,
    /// snake_case; header and z optional), or one PoseCandidate (msg/PoseCandidate.msg: a line
    /// with grasp_pose; docs/poses.md). Standard input when absent or "-".
    pub(crate) file: Option<PathBuf>,
    /// The axis of the gripper's tool frame that the fingers of a pose candidate close along:
    /// x, y or z (parameter closing_axis, default y).
    #[arg(long, value_name = "AXIS", value_parser = super::parse_name::<ClosingAxis>)]
    pub(crate) closing_axis: Option<ClosingAxis>,
    #[command(flatten)]
    pub(crate) options: SolveOptions,
}

/// Solves every line; a bad line gets status 2 with its line number and the run goes on.
pub(crate) fn run(args: &Args) -> anyhow::Result<()> {
    let (_, with) = args.options.answering(args.closing_axis)?;
    let stdout = std::io::stdout();
    let out = std::io::BufWriter::new(stdout.lock());
    let warn = |message: &str| log::warn!("{message}");
    let counts = match &args.file {
        Some(path) if path.as_os_str() != "-" => {
            let file = std::fs::File::open(path)
                .with_context(|| format!("cannot open {}", path.display()))?;
            answer_lines(BufReader::new(file), out, &with, warn)
        }
        _ => answer_lines(std::io::stdin().lock(), out, &with, warn),
    }?;
    log::info!(
        "{} candidates, {} not solved",
        counts.answered,
        counts.not_solved
    );
    Ok(())
}
