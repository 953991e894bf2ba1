//! `grasp_orient recover BROKEN.mcap -o FIXED.mcap`: what a killed recording holds, as a
//! finished file.

use grasp_orient::record::bag;
use std::path::PathBuf;

/// Arguments of `recover`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// A recording that was cut short (killed process, full disk).
    pub broken: PathBuf,
    /// Where to write the recovered recording.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Recovers and says what was saved.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let got = bag::recover(&args.broken, &args.output)?;
    for (topic, count) in &got.per_topic {
        println!("{topic}: {count} messages");
    }
    match &got.stopped {
        Some(why) => println!(
            "{} ended early ({why}); everything before that is in {}",
            args.broken.display(),
            args.output.display()
        ),
        None => println!(
            "{} was complete; copied to {}",
            args.broken.display(),
            args.output.display()
        ),
    }
    Ok(())
}
