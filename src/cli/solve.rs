//! `grasp_orient solve [FILE]`: JSON lines in, one JSON line out per candidate.

use super::SolveOptions;
use anyhow::Context;
use grasp_orient::msg::{invalid, GraspCandidate, GripRecommendation};
use grasp_orient::sets::answer_one;
use std::io::{BufRead, BufReader, Write};
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
    let input: Box<dyn BufRead> = match &args.file {
        Some(path) if path.as_os_str() != "-" => Box::new(BufReader::new(
            std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?,
        )),
        _ => Box::new(std::io::stdin().lock()),
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let (mut total, mut bad) = (0usize, 0usize);
    for (index, line) in input.lines().enumerate() {
        let number = index + 1;
        let line = line.with_context(|| format!("cannot read line {number}"))?;
        if line.trim().is_empty() {
            continue;
        }
        total += 1;
        let mut reply = match serde_json::from_str::<GraspCandidate>(&line) {
            Ok(candidate) => answer_one(&candidate, &settings, &rules),
            Err(e) => invalid(&partial(&line), &e),
        };
        if reply.status == GripRecommendation::STATUS_INVALID_INPUT {
            reply.message = format!("line {number}: {}", reply.message);
        }
        if reply.status != GripRecommendation::STATUS_OK {
            bad += 1;
            log::warn!("{}", reply.message);
        }
        serde_json::to_writer(&mut out, &reply).context("cannot write the answer")?;
        out.write_all(b"\n").context("cannot write the answer")?;
        out.flush().context("cannot write the answer")?;
    }
    log::info!("{total} candidates, {bad} not solved");
    Ok(())
}

/// What can be salvaged from a line that is not a valid candidate: its `id` and `header`, so the
/// answer can still be matched to it.
pub(super) fn partial(line: &str) -> GraspCandidate {
    let mut out = GraspCandidate::default();
    if let Ok(value) = serde_json::from_str::<serde_json::Value>(line) {
        if let Some(id) = value.get("id").and_then(|v| v.as_str()) {
            out.id = id.to_string();
        }
        if let Some(header) = value
            .get("header")
            .and_then(|h| serde_json::from_value(h.clone()).ok())
        {
            out.header = header;
        }
    }
    out
}
