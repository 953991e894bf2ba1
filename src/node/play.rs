//! `grasp_orient play BAG`: republishes recorded candidates to the live graph at the recorded
//! pace (or `--rate` times it), like `ros2 bag play`.

use super::ros_args::RosArgs;
use super::{create_topic, qos, Graph};
use crate::msg::GraspCandidate;
use crate::record::bag;
use anyhow::{bail, Context as _};
use async_signal::{Signal, Signals};
use futures::{FutureExt, StreamExt};
use ros2_client::{NodeName, NodeOptions};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `play`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// A recording with grasp_orient/msg/GraspCandidate messages.
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

/// Publishes every candidate of the bag on `grasp_candidates` (remappable with `--ros-args`).
pub fn run(args: &Args, ros_argv: &[String]) -> anyhow::Result<()> {
    if !(args.rate.is_finite() && args.rate >= 0.0) {
        bail!("--rate must be a finite number >= 0, got {}", args.rate);
    }
    let mut signals = Signals::new([Signal::Int, Signal::Term]).context("cannot catch signals")?;
    let ros = RosArgs::parse(ros_argv)?;
    let recorded = bag::read(&args.bag)?;
    if recorded.candidates.is_empty() {
        bail!(
            "{}: no grasp_orient/msg/GraspCandidate messages",
            args.bag.display()
        );
    }
    let graph = Graph::from_env()?;
    let context = graph.context()?;
    let name = ros
        .node_name
        .clone()
        .unwrap_or_else(|| "grasp_orient_play".into());
    let mut node = context
        .new_node(
            NodeName::new(&ros.namespace(), &name).context("invalid node name or namespace")?,
            NodeOptions::new().start_parameter_services(false),
        )
        .context("cannot create the node")?;
    let topic_name = ros.topic("grasp_candidates", &name);
    let qos = qos(args.depth);
    let topic = create_topic(&node, &topic_name, "grasp_orient", "GraspCandidate", &qos)?;
    let publisher = node.create_publisher::<GraspCandidate>(&topic, None)?;
    let executor = smol::Executor::new();
    let spinner = executor.spawn(node.spinner().context("cannot start the spinner")?.spin());
    let total = recorded.candidates.len();
    let outcome = smol::block_on(executor.run(async {
        let mut wait = std::pin::pin!(publisher.wait_for_subscription(&node).fuse());
        let mut timeout = std::pin::pin!(FutureExt::fuse(smol::Timer::after(
            Duration::from_secs_f64(args.wait)
        )));
        futures::select! {
            _ = wait => {}
            _ = timeout => bail!("no subscriber on {topic_name} after {} s", args.wait),
            _ = signals.next().fuse() => return Ok(0),
        }
        log::info!(
            "playing {total} candidates from {} on {topic_name}",
            args.bag.display()
        );
        let start = Instant::now();
        let first = recorded.candidates[0].log_time;
        let mut sent = 0usize;
        for c in &recorded.candidates {
            if args.rate > 0.0 {
                let offset = c.log_time.saturating_sub(first) as f64 / 1e9 / args.rate;
                let due = start + Duration::from_secs_f64(offset);
                let mut sleep = std::pin::pin!(FutureExt::fuse(smol::Timer::at(due)));
                futures::select! {
                    _ = sleep => {}
                    _ = signals.next().fuse() => break,
                }
            }
            publisher
                .async_publish(c.message.clone())
                .await
                .map_err(|e| anyhow::anyhow!("cannot publish: {e:?}"))?;
            sent += 1;
        }
        // Let reliable delivery finish before leaving.
        smol::Timer::after(Duration::from_millis(500)).await;
        Ok(sent)
    }));
    drop(publisher);
    drop(node);
    smol::block_on(executor.run(async {
        if let Err(e) = spinner.await {
            log::warn!("the spinner ended with an error: {e:?}");
        }
    }));
    drop(executor);
    drop(context);
    let sent = outcome?;
    println!("published {sent} of {total} candidates on {topic_name}");
    Ok(())
}
