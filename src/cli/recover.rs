//! `grasp_orient recover BROKEN.mcap -o FIXED.mcap`: what a cut-short or damaged recording still
//! holds, as a finished file. Only what verifies is kept; what is dropped is counted per topic.
//!
//! The outcome, for `main` to turn into an exit code: `Ok` when nothing was lost; [`Negative`]
//! when anything was dropped or could not be verified; any other error is trouble (the input is
//! not an MCAP recording, the output cannot be written).

use super::Negative;
use crate::record::recover;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `recover`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Args {
    /// A recording that was cut short (killed process, full disk) or damaged.
    pub(crate) broken: PathBuf,
    /// Where to write the recovered recording: written beside it and renamed into place when
    /// complete (a failure leaves what was there); never BROKEN itself.
    #[arg(short, long)]
    pub(crate) output: PathBuf,
}

/// Recovers and says what was saved and what was lost.
pub(crate) fn run(args: &Args) -> anyhow::Result<()> {
    let got = recover::recover(&args.broken, &args.output)?;
    let mut out = std::io::stdout().lock();
    let topics: std::collections::BTreeSet<&String> =
        got.kept.keys().chain(got.dropped.keys()).collect();
    for topic in topics {
        let kept = got.kept.get(topic).copied().unwrap_or(0);
        match got.dropped.get(topic) {
            Some(lost) => writeln!(out, "{topic}: {kept} messages kept, {lost} dropped")?,
            None => writeln!(out, "{topic}: {kept} messages kept")?,
        }
    }
    if got.metadata > 0 {
        writeln!(out, "{} metadata records kept", got.metadata)?;
    }
    for note in &got.notes {
        writeln!(out, "note: {note}")?;
    }
    for damage in &got.damage {
        writeln!(out, "damage: {} {damage}", args.broken.display())?;
    }
    if got.damage_count > got.damage.len() as u64 {
        writeln!(
            out,
            "damage: {} more places",
            got.damage_count - got.damage.len() as u64
        )?;
    }
    writeln!(
        out,
        "recovered {} messages in {} chunks of {} into {}",
        got.kept_total(),
        got.chunks_kept,
        args.broken.display(),
        args.output.display()
    )?;
    if got.lost_anything() {
        let counted = got.dropped_total();
        let uncounted = if got.uncounted > 0 {
            format!(
                ", and {} damaged place{} whose messages nothing counts",
                got.uncounted,
                if got.uncounted == 1 { "" } else { "s" }
            )
        } else {
            String::new()
        };
        return Err(Negative(format!(
            "{}: {counted} messages and {} chunk{} dropped{uncounted}; {} damaged place{} in all",
            args.broken.display(),
            got.chunks_dropped,
            if got.chunks_dropped == 1 { "" } else { "s" },
            got.damage_count,
            if got.damage_count == 1 { "" } else { "s" }
        ))
        .into());
    }
    Ok(())
}
