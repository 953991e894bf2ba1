//! Republishing recorded candidates, candidate sets, pose candidates and pose sets to the live
//! graph at the recorded pace (or `rate` times it), like `ros2 bag play`; `grasp_orient play`
//! (`cli/play.rs`) reads the bag and opens the session.

use super::session::{create_topic, qos, Session, Shutdown};
use crate::msg::{GraspCandidate, GraspCandidateSet, PoseCandidate, PoseCandidateSet, RosMessage};
use crate::record::bag::{Bag, Recorded};
use anyhow::bail;
use futures::future::BoxFuture;
use futures::FutureExt;
use ros2_client::{Node, Publisher};
use std::path::Path;
use std::time::{Duration, Instant};

/// How to play.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pace {
    /// Speed relative to the recording; 0 sends as fast as possible.
    pub rate: f64,
    /// Seconds to wait for a subscriber before starting.
    pub wait: f64,
    /// QoS history depth of the publisher (reliable, volatile).
    pub depth: i64,
}

/// What a play sent, and where.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Played {
    /// Candidates sent.
    pub candidates: usize,
    /// Candidate sets sent.
    pub sets: usize,
    /// Pose candidates sent.
    pub poses: usize,
    /// Pose sets sent.
    pub pose_sets: usize,
    /// The candidates topic's absolute name.
    pub candidates_topic: String,
    /// The sets topic's absolute name.
    pub sets_topic: String,
    /// The pose candidates topic's absolute name.
    pub poses_topic: String,
    /// The pose sets topic's absolute name.
    pub pose_sets_topic: String,
}

/// One message to play.
enum Item<'a> {
    Candidate(&'a GraspCandidate),
    Set(&'a GraspCandidateSet),
    Pose(&'a PoseCandidate),
    PoseSet(&'a PoseCandidateSet),
}

/// The messages in recorded order (by `log_time`; on a tie candidates, then sets, then pose
/// candidates, then pose sets, each in file order), each with its time.
fn merged(bag: &Bag) -> Vec<(u64, Item<'_>)> {
    fn timed<'a, M>(
        recorded: &'a [Recorded<M>],
        item: impl Fn(&'a M) -> Item<'a> + 'a,
    ) -> impl Iterator<Item = (u64, Item<'a>)> + 'a {
        recorded.iter().map(move |r| (r.log_time, item(&r.message)))
    }
    let mut all: Vec<(u64, Item<'_>)> = timed(&bag.streams.candidates.requests, Item::Candidate)
        .chain(timed(&bag.streams.sets.requests, Item::Set))
        .chain(timed(&bag.streams.poses.requests, Item::Pose))
        .chain(timed(&bag.streams.pose_sets.requests, Item::PoseSet))
        .collect();
    // Stable: the chained order is kept among equal times.
    all.sort_by_key(|(t, _)| *t);
    all
}

/// The four publishers, one per topic played.
struct Publishers {
    candidates: Publisher<GraspCandidate>,
    sets: Publisher<GraspCandidateSet>,
    poses: Publisher<PoseCandidate>,
    pose_sets: Publisher<PoseCandidateSet>,
}

/// A reliable, volatile publisher of `M` on `topic`.
fn publisher<M: RosMessage + serde::Serialize>(
    session: &mut Session,
    topic: &str,
    depth: i64,
) -> anyhow::Result<Publisher<M>> {
    let topic = create_topic::<M>(session.node(), topic, &qos(depth))?;
    Ok(session.node_mut().create_publisher::<M>(&topic, None)?)
}

impl Publishers {
    fn create(session: &mut Session, names: &Played, depth: i64) -> anyhow::Result<Self> {
        Ok(Self {
            candidates: publisher(session, &names.candidates_topic, depth)?,
            sets: publisher(session, &names.sets_topic, depth)?,
            poses: publisher(session, &names.poses_topic, depth)?,
            pose_sets: publisher(session, &names.pose_sets_topic, depth)?,
        })
    }

    /// Publishes one item and counts it in `played`.
    async fn send(&self, item: &Item<'_>, played: &mut Played) -> anyhow::Result<()> {
        let failed =
            |what: &str, e: &dyn std::fmt::Debug| anyhow::anyhow!("cannot publish {what}: {e:?}");
        match item {
            Item::Candidate(c) => {
                let sent = self.candidates.async_publish((*c).clone()).await;
                sent.map_err(|e| failed("a candidate", &e))?;
                played.candidates += 1;
            }
            Item::Set(s) => {
                let sent = self.sets.async_publish((*s).clone()).await;
                sent.map_err(|e| failed("a set", &e))?;
                played.sets += 1;
            }
            Item::Pose(p) => {
                let sent = self.poses.async_publish((*p).clone()).await;
                sent.map_err(|e| failed("a pose candidate", &e))?;
                played.poses += 1;
            }
            Item::PoseSet(s) => {
                let sent = self.pose_sets.async_publish((*s).clone()).await;
                sent.map_err(|e| failed("a pose set", &e))?;
                played.pose_sets += 1;
            }
        }
        Ok(())
    }

    /// For each topic with something to send, the wait for its first subscriber, and its name.
    fn waits<'a>(
        &'a self,
        node: &'a Node,
        bag: &Bag,
        names: &'a Played,
    ) -> Vec<(BoxFuture<'a, ()>, &'a str)> {
        let mut waits = Vec::new();
        if !bag.streams.candidates.requests.is_empty() {
            let found = self.candidates.wait_for_subscription(node).boxed();
            waits.push((found, names.candidates_topic.as_str()));
        }
        if !bag.streams.sets.requests.is_empty() {
            let found = self.sets.wait_for_subscription(node).boxed();
            waits.push((found, names.sets_topic.as_str()));
        }
        if !bag.streams.poses.requests.is_empty() {
            let found = self.poses.wait_for_subscription(node).boxed();
            waits.push((found, names.poses_topic.as_str()));
        }
        if !bag.streams.pose_sets.requests.is_empty() {
            let found = self.pose_sets.wait_for_subscription(node).boxed();
            waits.push((found, names.pose_sets_topic.as_str()));
        }
        waits
    }
}

/// Waits until each publisher with something to send has a subscriber, or `wait` seconds pass;
/// false when a shutdown was asked for.
async fn wait_for_subscribers(
    shutdown: &mut Shutdown,
    waits: Vec<(BoxFuture<'_, ()>, &str)>,
    wait: f64,
) -> anyhow::Result<bool> {
    // A wait too long for a clock to hold never times out (a stop request still ends it).
    let timer =
        Duration::try_from_secs_f64(wait).map_or_else(|_| smol::Timer::never(), smol::Timer::after);
    let mut deadline = std::pin::pin!(FutureExt::fuse(timer));
    for (found, topic) in waits {
        let mut found = found.fuse();
        futures::select! {
            _ = found => {}
            _ = deadline => bail!("no subscriber on {topic} after {wait} s"),
            _ = shutdown.requested().fuse() => return Ok(false),
        }
    }
    Ok(true)
}

/// Waits until `offset` seconds after `start`; false when a stop request comes first. An
/// offset beyond what a clock can hold is never due (a stop request still ends the wait).
async fn paced(start: Instant, offset: f64, shutdown: &mut Shutdown) -> bool {
    let due = Duration::try_from_secs_f64(offset)
        .ok()
        .and_then(|d| start.checked_add(d));
    let timer = due.map_or_else(smol::Timer::never, smol::Timer::at);
    let mut sleep = std::pin::pin!(FutureExt::fuse(timer));
    futures::select! {
        _ = sleep => true,
        _ = shutdown.requested().fuse() => false,
    }
}

/// Publishes the bag's candidates on `grasp_candidates`, its sets on `grasp_candidate_sets`, its
/// pose candidates on `pose_candidates` and its pose sets on `pose_candidate_sets` (all
/// remappable), in the order and at the pace they were received (their `log_time`): waits for a
/// subscriber on each topic with something to send, keeps the recorded gaps, stops early on
/// SIGINT or SIGTERM.
pub(crate) fn publish(
    session: &mut Session,
    source: &Path,
    bag: &Bag,
    pace: Pace,
) -> anyhow::Result<Played> {
    let names = Played {
        candidates_topic: session.topic_name("grasp_candidates"),
        sets_topic: session.topic_name("grasp_candidate_sets"),
        poses_topic: session.topic_name("pose_candidates"),
        pose_sets_topic: session.topic_name("pose_candidate_sets"),
        ..Played::default()
    };
    let publishers = Publishers::create(session, &names, pace.depth)?;
    let items = merged(bag);
    let result: anyhow::Result<Played> = session.run(async |node, shutdown| {
        let mut played = names.clone();
        let waits = publishers.waits(node, bag, &names);
        if !wait_for_subscribers(shutdown, waits, pace.wait).await? {
            return Ok(played);
        }
        log::info!(
            "playing {} candidates, {} sets, {} pose candidates and {} pose sets from {} on {}, \
             {}, {} and {}",
            bag.streams.candidates.requests.len(),
            bag.streams.sets.requests.len(),
            bag.streams.poses.requests.len(),
            bag.streams.pose_sets.requests.len(),
            source.display(),
            names.candidates_topic,
            names.sets_topic,
            names.poses_topic,
            names.pose_sets_topic
        );
        let start = Instant::now();
        let first = items.first().map_or(0, |(t, _)| *t);
        for (time, item) in &items {
            if pace.rate > 0.0 {
                let offset = time.saturating_sub(first) as f64 / 1e9 / pace.rate;
                if !paced(start, offset, shutdown).await {
                    break;
                }
            }
            publishers.send(item, &mut played).await?;
        }
        let sent = played.candidates + played.sets + played.poses + played.pose_sets;
        log::debug!("sent {sent} of {} messages", items.len());
        // Let reliable delivery finish before leaving.
        smol::Timer::after(Duration::from_millis(500)).await;
        Ok(played)
    });
    drop(publishers);
    result
}
