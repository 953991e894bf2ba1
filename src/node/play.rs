//! Republishing recorded candidates to the live graph at the recorded pace (or `rate` times it),
//! like `ros2 bag play`; `grasp_orient play` (`cli/play.rs`) reads the bag and opens the session.

use super::session::{create_topic, qos, Session};
use crate::msg::GraspCandidate;
use crate::record::bag::Recorded;
use anyhow::bail;
use futures::FutureExt;
use std::path::Path;
use std::time::{Duration, Instant};

/// How to play.
#[derive(Debug, Clone, Copy)]
pub struct Pace {
    /// Speed relative to the recording; 0 sends as fast as possible.
    pub rate: f64,
    /// Seconds to wait for a subscriber before starting.
    pub wait: f64,
    /// QoS history depth of the publisher (reliable, volatile).
    pub depth: i64,
}

/// Publishes `candidates` (received at their `log_time`) on `grasp_candidates` (remappable):
/// waits for a subscriber, keeps the recorded gaps, stops early on SIGINT or SIGTERM. The number
/// sent, and the topic's absolute name.
pub fn publish(
    session: &mut Session,
    source: &Path,
    candidates: &[Recorded<GraspCandidate>],
    pace: Pace,
) -> anyhow::Result<(usize, String)> {
    let topic_name = session.topic_name("grasp_candidates");
    let topic = create_topic::<GraspCandidate>(session.node(), &topic_name, &qos(pace.depth))?;
    let publisher = session
        .node_mut()
        .create_publisher::<GraspCandidate>(&topic, None)?;
    let total = candidates.len();
    let sent = session.run(async |node, shutdown| {
        let mut wait = std::pin::pin!(publisher.wait_for_subscription(node).fuse());
        let timer = Duration::try_from_secs_f64(pace.wait)
            .map_or_else(|_| smol::Timer::never(), smol::Timer::after);
        let mut timeout = std::pin::pin!(FutureExt::fuse(timer));
        futures::select! {
            _ = wait => {}
            _ = timeout => bail!("no subscriber on {topic_name} after {} s", pace.wait),
            _ = shutdown.requested().fuse() => return Ok(0),
        }
        log::info!(
            "playing {total} candidates from {} on {topic_name}",
            source.display()
        );
        let start = Instant::now();
        let first = candidates.first().map_or(0, |c| c.log_time);
        let mut sent = 0usize;
        for c in candidates {
            if pace.rate > 0.0 {
                let offset = c.log_time.saturating_sub(first) as f64 / 1e9 / pace.rate;
                // Beyond what a clock can hold: never due (a stop request still ends it).
                let due = Duration::try_from_secs_f64(offset)
                    .ok()
                    .and_then(|d| start.checked_add(d));
                let timer = due.map_or_else(smol::Timer::never, smol::Timer::at);
                let mut sleep = std::pin::pin!(FutureExt::fuse(timer));
                futures::select! {
                    _ = sleep => {}
                    _ = shutdown.requested().fuse() => break,
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
    });
    drop(publisher);
    Ok((sent?, topic_name))
}
