//! `grasp_orient play BAG`: republishes recorded candidates, candidate sets, pose candidates and
//! pose sets to the live graph at the recorded pace (or `--rate` times it), like `ros2 bag play`.

use crate::node::play::{publish, Pace};
use crate::node::session::Start;
use crate::record::bag;
use anyhow::bail;
use ros2_client::NodeOptions;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `play`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct Args {
    /// A recording with grasp_orient/msg/GraspCandidate, GraspCandidateSet, PoseCandidate or
    /// PoseCandidateSet messages.
    pub bag: PathBuf,
    /// Speed relative to the recording (2 = twice as fast), from 0.001 to 1000; 0 sends as fast
    /// as possible.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = rate)]
    pub rate: f64,
    /// Seconds to wait for a subscriber before starting, from 0 to 86400.
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true,
          value_parser = super::real_in(0.0, 86_400.0))]
    pub wait: f64,
    /// QoS history depth of the publisher (reliable, volatile), as qos_depth: 1 to 100000.
    #[arg(long, default_value_t = 1000, allow_negative_numbers = true,
          value_parser = super::parameter::<i64>("qos_depth"))]
    pub depth: i64,
}

/// `--rate`: 0, or a speed-up from 0.001 to 1000.
fn rate(text: &str) -> Result<f64, super::BadValue> {
    match super::real_in(0.0, 1e3)(text)? {
        r if r == 0.0 || r >= 1e-3 => Ok(r),
        rate => Err(super::BadValue::Rate { rate }),
    }
}

/// Publishes every candidate of the bag on `grasp_candidates`, every set on
/// `grasp_candidate_sets`, every pose candidate on `pose_candidates` and every pose set on
/// `pose_candidate_sets` (remappable with `--ros-args`); one summary line per kind the bag holds
/// (candidates always).
pub(crate) fn run(args: &Args, ros_argv: &[String]) -> anyhow::Result<()> {
    let start = Start::new(ros_argv)?;
    let recorded = bag::read(&args.bag)?;
    if recorded.streams.candidates.requests.is_empty()
        && recorded.streams.sets.requests.is_empty()
        && recorded.streams.poses.requests.is_empty()
        && recorded.streams.pose_sets.requests.is_empty()
    {
        bail!(
            "{}: no grasp_orient/msg/GraspCandidate, GraspCandidateSet, PoseCandidate or \
             PoseCandidateSet messages",
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
    let played = publish(&mut session, &args.bag, &recorded, pace);
    session.close();
    let played = played?;
    writeln!(
        std::io::stdout(),
        "published {} of {} candidates on {}",
        played.candidates,
        recorded.streams.candidates.requests.len(),
        played.candidates_topic
    )?;
    if !recorded.streams.sets.requests.is_empty() {
        writeln!(
            std::io::stdout(),
            "published {} of {} candidate sets on {}",
            played.sets,
            recorded.streams.sets.requests.len(),
            played.sets_topic
        )?;
    }
    if !recorded.streams.poses.requests.is_empty() {
        writeln!(
            std::io::stdout(),
            "published {} of {} pose candidates on {}",
            played.poses,
            recorded.streams.poses.requests.len(),
            played.poses_topic
        )?;
    }
    if !recorded.streams.pose_sets.requests.is_empty() {
        writeln!(
            std::io::stdout(),
            "published {} of {} pose sets on {}",
            played.pose_sets,
            recorded.streams.pose_sets.requests.len(),
            played.pose_sets_topic
        )?;
    }
    Ok(())
}
