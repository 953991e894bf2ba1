//! `grasp_orient solve [FILE]`: JSON lines in, one JSON line out per candidate.

use super::SolveOptions;
use anyhow::Context;
use grasp_orient::jsonl::answer_lines;
use std::io::BufReader;
use std::path::PathBuf;

/// Arguments of `solve`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// File of JSON lines, one GraspCandidate per line (fields as in msg/GraspCandidate.msg,
    /// snake_case; header and z optional). Standard input when absent or "-".
    pub file: Option<PathBuf>,
    #[command(flatten)]
    pub options: SolveOptions,
}

/// Solves every line; a bad line gets status 2 with its line number and the run goes on.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (_, settings, rules) = args.options.configured()?;
    let stdout = std::io::stdout();
    let out = std::io::BufWriter::new(stdout.lock());
    let warn = |message: &str| log::warn!("{message}");
    let counts = match &args.file {
        Some(path) if path.as_os_str() != "-" => {
            let file = std::fs::File::open(path)
                .with_context(|| format!("cannot open {}", path.display()))?;
            answer_lines(BufReader::new(file), out, &settings, &rules, warn)
        }
        _ => answer_lines(std::io::stdin().lock(), out, &settings, &rules, warn),
    }?;
    log::info!(
        "{} candidates, {} not solved",
        counts.answered,
        counts.not_solved
    );
    Ok(())
}
