//! `grasp_orient play BAG`: republishes the recorded requests of every kind (candidates,
//! candidate sets, pose candidates, pose sets) to the live graph at the recorded pace (or `--rate` times it), like `ros2 bag play`.

use crate::kind::{Candidates, Kind};
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
    /// A recording with grasp_orient requests: candidates, candidate sets, pose candidates or
    /// pose sets.
    pub(crate) bag: PathBuf,
    /// Speed relative to the recording (2 = twice as fast), from 0.001 to 1000; 0 sends as fast
    /// as possible.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = rate)]
    pub(crate) rate: f64,
    /// Seconds to wait for a subscriber before starting, from 0 to 86400.
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true,
          value_parser = super::real_in(0.0, 86_400.0))]
    pub(crate) wait: f64,
    /// QoS history depth of the publisher (reliable, volatile), as qos_depth: 1 to 100000.
    #[arg(long, default_value_t = 1000, allow_negative_numbers = true,
          value_parser = super::parameter::<i64>("qos_depth"))]
    pub(crate) depth: i64,
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
    if recorded.streams.request_counts().iter().all(|n| *n == 0) {
        bail!(
            "{}: no {} messages",
            args.bag.display(),
            crate::kind::request_types()
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
    let recorded_requests = recorded.streams.request_counts();
    let mut out = std::io::stdout().lock();
    for (k, plural) in crate::kind::plurals().into_iter().enumerate() {
        // Candidates always (the node's first kind); another kind when the bag holds it.
        if k == Candidates::INDEX || recorded_requests[k] > 0 {
            writeln!(
                out,
                "published {} of {} {plural} on {}",
                played.sent[k], recorded_requests[k], played.topics[k]
            )?;
        }
    }
    Ok(())
}
