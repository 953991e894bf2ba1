//! Republishing recorded candidates and candidate sets to the live graph at the recorded pace (or
//! `rate` times it), like `ros2 bag play`; `grasp_orient play` (`cli/play.rs`) reads the bag and
//! opens the session.

use super::session::{create_topic, qos, Session};
use crate::msg::{GraspCandidate, GraspCandidateSet};
use crate::record::bag::Recorded;
use anyhow::bail;
use futures::FutureExt;
use ros2_client::{Node, Publisher};
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

/// What a play sent, and where.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Played {
    /// Candidates sent.
    pub candidates: usize,
    /// Candidate sets sent.
    pub sets: usize,
    /// The candidates topic's absolute name.
    pub candidates_topic: String,
    /// The sets topic's absolute name.
    pub sets_topic: String,
}

/// One message to play.
enum Item<'a> {
    Candidate(&'a GraspCandidate),
    Set(&'a GraspCandidateSet),
}

/// The messages in recorded order (by `log_time`, candidates first on a tie), each with its time.
fn merged<'a>(
    candidates: &'a [Recorded<GraspCandidate>],
    sets: &'a [Recorded<GraspCandidateSet>],
) -> Vec<(u64, Item<'a>)> {
    let mut all: Vec<(u64, Item<'a>)> = candidates
        .iter()
        .map(|c| (c.log_time, Item::Candidate(&c.message)))
        .chain(sets.iter().map(|s| (s.log_time, Item::Set(&s.message))))
        .collect();
    // Stable: file order is kept among equal times, candidates before sets.
    all.sort_by_key(|(t, _)| *t);
    all
}

/// Waits until each publisher with something to send has a subscriber, or `wait` seconds pass;
/// false when a shutdown was asked for.
async fn wait_for_subscribers(
    node: &Node,
    shutdown: &mut super::session::Shutdown,
    candidates: Option<(&Publisher<GraspCandidate>, &str)>,
    sets: Option<(&Publisher<GraspCandidateSet>, &str)>,
    wait: f64,
) -> anyhow::Result<bool> {
    // A wait too long for a clock to hold never times out (a stop request still ends it).
    let timer =
        Duration::try_from_secs_f64(wait).map_or_else(|_| smol::Timer::never(), smol::Timer::after);
    let mut deadline = std::pin::pin!(FutureExt::fuse(timer));
    if let Some((publisher, topic)) = candidates {
        let mut found = std::pin::pin!(publisher.wait_for_subscription(node).fuse());
        futures::select! {
            _ = found => {}
            _ = deadline => bail!("no subscriber on {topic} after {wait} s"),
            _ = shutdown.requested().fuse() => return Ok(false),
        }
    }
    if let Some((publisher, topic)) = sets {
        let mut found = std::pin::pin!(publisher.wait_for_subscription(node).fuse());
        futures::select! {
            _ = found => {}
            _ = deadline => bail!("no subscriber on {topic} after {wait} s"),
            _ = shutdown.requested().fuse() => return Ok(false),
        }
    }
    Ok(true)
}

/// Publishes `candidates` on `grasp_candidates` and `sets` on `grasp_candidate_sets` (both
/// remappable), in the order and at the pace they were received (their `log_time`): waits for a
/// subscriber on each topic with something to send, keeps the recorded gaps, stops early on
/// SIGINT or SIGTERM.
pub fn publish(
    session: &mut Session,
    source: &Path,
    candidates: &[Recorded<GraspCandidate>],
    sets: &[Recorded<GraspCandidateSet>],
    pace: Pace,
) -> anyhow::Result<Played> {
    let mut played = Played {
        candidates_topic: session.topic_name("grasp_candidates"),
        sets_topic: session.topic_name("grasp_candidate_sets"),
        ..Played::default()
    };
    let qos = qos(pace.depth);
    let topic = create_topic::<GraspCandidate>(session.node(), &played.candidates_topic, &qos)?;
    let set_topic = create_topic::<GraspCandidateSet>(session.node(), &played.sets_topic, &qos)?;
    let publisher = session
        .node_mut()
        .create_publisher::<GraspCandidate>(&topic, None)?;
    let set_publisher = session
        .node_mut()
        .create_publisher::<GraspCandidateSet>(&set_topic, None)?;
    let items = merged(candidates, sets);
    let (names, total) = (played.clone(), items.len());
    let result: anyhow::Result<(usize, usize)> = session.run(async |node, shutdown| {
        let wanted =
            (!candidates.is_empty()).then_some((&publisher, names.candidates_topic.as_str()));
        let set_wanted = (!sets.is_empty()).then_some((&set_publisher, names.sets_topic.as_str()));
        if !wait_for_subscribers(node, shutdown, wanted, set_wanted, pace.wait).await? {
            return Ok((0, 0));
        }
        log::info!(
            "playing {} candidates and {} sets from {} on {} and {}",
            candidates.len(),
            sets.len(),
            source.display(),
            names.candidates_topic,
            names.sets_topic
        );
        let start = Instant::now();
        let first = items.first().map_or(0, |(t, _)| *t);
        let (mut sent, mut sent_sets) = (0usize, 0usize);
        for (time, item) in &items {
            if pace.rate > 0.0 {
                let offset = time.saturating_sub(first) as f64 / 1e9 / pace.rate;
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
            match item {
                Item::Candidate(c) => {
                    publisher
                        .async_publish((*c).clone())
                        .await
                        .map_err(|e| anyhow::anyhow!("cannot publish: {e:?}"))?;
                    sent += 1;
                }
                Item::Set(s) => {
                    set_publisher
                        .async_publish((*s).clone())
                        .await
                        .map_err(|e| anyhow::anyhow!("cannot publish a set: {e:?}"))?;
                    sent_sets += 1;
                }
            }
        }
        log::debug!("sent {} of {total} messages", sent + sent_sets);
        // Let reliable delivery finish before leaving.
        smol::Timer::after(Duration::from_millis(500)).await;
        Ok((sent, sent_sets))
    });
    drop(publisher);
    drop(set_publisher);
    let (sent, sent_sets) = result?;
    played.candidates = sent;
    played.sets = sent_sets;
    Ok(played)
}
