//! `grasp_orient play BAG`: republishes recorded candidates to the live graph at the recorded
//! pace (or `--rate` times it), like `ros2 bag play`.

use anyhow::bail;
use grasp_orient::node::play::{publish, Pace};
use grasp_orient::node::session::Start;
use grasp_orient::record::bag;
use ros2_client::NodeOptions;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `play`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// A recording with grasp_orient/msg/GraspCandidate or GraspCandidateSet messages.
    pub bag: PathBuf,
    /// Speed relative to the recording (2 = twice as fast); 0 sends as fast as possible.
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Seconds to wait for a subscriber before starting.
    #[arg(long, default_value_t = 10.0)]
    pub wait: f64,
    /// QoS history depth of the publisher (reliable, volatile).
    #[arg(long, default_value_t = 1000)]
    pub depth: i64,
}

/// Publishes every candidate of the bag on `grasp_candidates` and every set on
/// `grasp_candidate_sets` (remappable with `--ros-args`).
pub fn run(args: &Args, ros_argv: &[String]) -> anyhow::Result<()> {
    if !(args.rate.is_finite() && args.rate >= 0.0) {
        bail!("--rate must be a finite number >= 0, got {}", args.rate);
    }
    let start = Start::new(ros_argv)?;
    let recorded = bag::read(&args.bag)?;
    if recorded.candidates.is_empty() && recorded.candidate_sets.is_empty() {
        bail!(
            "{}: no grasp_orient/msg/GraspCandidate or GraspCandidateSet messages",
            args.bag.display()
        );
    }
    let name = start.node_name("grasp_orient_play");
    let mut session = start.open(&name, NodeOptions::new().start_parameter_services(false))?;
    let pace = Pace {
        rate: args.rate,
        wait: args.wait,
        depth: args.depth,
    };
    let played = publish(
        &mut session,
        &args.bag,
        &recorded.candidates,
        &recorded.candidate_sets,
        pace,
    );
    session.close();
    let played = played?;
    writeln!(
        std::io::stdout(),
        "published {} of {} candidates on {}",
        played.candidates,
        recorded.candidates.len(),
        played.candidates_topic
    )?;
    if !recorded.candidate_sets.is_empty() {
        writeln!(
            std::io::stdout(),
            "published {} of {} candidate sets on {}",
            played.sets,
            recorded.candidate_sets.len(),
            played.sets_topic
        )?;
    }
    Ok(())
}
