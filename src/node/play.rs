//! Republishing the recorded requests of every kind (candidates, candidate sets, pose
//! candidates, pose sets) to the live graph at the recorded pace (or `rate` times it), like
//! `ros2 bag play`; `grasp_orient play` (`cli/play.rs`) reads the bag and opens the session.

use super::session::{create_topic, qos, Session, Shutdown};
use crate::kind::{self, Kind, Visit};
use crate::record::bag::Bag;
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
    pub(crate) rate: f64,
    /// Seconds to wait for a subscriber before starting.
    pub(crate) wait: f64,
    /// QoS history depth of the publisher (reliable, volatile).
    pub(crate) depth: i64,
}

/// What a play sent of each kind, and where, by [`Kind::INDEX`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Played {
    /// Requests sent.
    pub(crate) sent: [usize; kind::COUNT],
    /// The requests' topic's absolute name.
    pub(crate) topics: [String; kind::COUNT],
}

/// The publisher of one kind's requests.
trait Player: Send + Sync {
    /// Publishes request `index` of the kind's stream in `bag`.
    fn send<'a>(&'a self, bag: &'a Bag, index: usize) -> BoxFuture<'a, anyhow::Result<()>>;
    /// Until the topic has a subscriber.
    fn subscribed<'a>(&'a self, node: &'a Node) -> BoxFuture<'a, ()>;
}

/// A publisher of `K`'s requests.
struct KindPlayer<K: Kind> {
    publisher: Publisher<K::Request>,
}

impl<K: Kind> Player for KindPlayer<K> {
    fn send<'a>(&'a self, bag: &'a Bag, index: usize) -> BoxFuture<'a, anyhow::Result<()>> {
        async move {
            let Some(r) = K::stream(&bag.streams).requests.get(index) else {
                return Ok(());
            };
            let sent = self.publisher.async_publish(r.message.clone()).await;
            sent.map_err(|e| anyhow::anyhow!("cannot publish {}: {e:?}", K::ONE))
        }
        .boxed()
    }

    fn subscribed<'a>(&'a self, node: &'a Node) -> BoxFuture<'a, ()> {
        self.publisher.wait_for_subscription(node).boxed()
    }
}

/// The messages in recorded order (by `log_time`; on a tie in [`Kind::INDEX`] order, each kind
/// in file order), each as its time, kind and index in its stream.
fn merged(bag: &Bag) -> Vec<(u64, usize, usize)> {
    struct Timed<'a>(&'a Bag, Vec<(u64, usize, usize)>);
    impl Visit for Timed<'_> {
        fn kind<K: Kind>(&mut self) {
            let requests = &K::stream(&self.0.streams).requests;
            let timed = requests.iter().enumerate();
            self.1.extend(timed.map(|(i, r)| (r.log_time, K::INDEX, i)));
        }
    }
    let mut all = Timed(bag, Vec::new());
    kind::each(&mut all);
    // Stable: the kinds' order is kept among equal times.
    all.1.sort_by_key(|(t, _, _)| *t);
    all.1
}

/// One publisher per kind, by [`Kind::INDEX`], each reliable and volatile on its topic.
fn players(
    session: &mut Session,
    topics: &[String; kind::COUNT],
    depth: i64,
) -> anyhow::Result<Vec<Box<dyn Player>>> {
    struct Make<'a> {
        session: &'a mut Session,
        topics: &'a [String; kind::COUNT],
        depth: i64,
        made: anyhow::Result<Vec<Box<dyn Player>>>,
    }
    impl Visit for Make<'_> {
        fn kind<K: Kind>(&mut self) {
            let Ok(made) = &mut self.made else {
                return;
            };
            let topic = &self.topics[K::INDEX];
            let created = create_topic::<K::Request>(self.session.node(), topic, &qos(self.depth))
                .and_then(|t| Ok(self.session.node_mut().create_publisher(&t, None)?));
            match created {
                Ok(publisher) => made.push(Box::new(KindPlayer::<K> { publisher })),
                Err(e) => self.made = Err(e),
            }
        }
    }
    let mut make = Make {
        session,
        topics,
        depth,
        made: Ok(Vec::new()),
    };
    kind::each(&mut make);
    make.made
}

/// For each kind with something to send, the wait for its topic's first subscriber, and its
/// name.
fn waits<'a>(
    players: &'a [Box<dyn Player>],
    node: &'a Node,
    bag: &Bag,
    topics: &'a [String; kind::COUNT],
) -> Vec<(BoxFuture<'a, ()>, &'a str)> {
    let counts = bag.streams.request_counts();
    players
        .iter()
        .zip(topics)
        .zip(counts)
        .filter(|(_, n)| *n > 0)
        .map(|((p, topic), _)| (p.subscribed(node), topic.as_str()))
        .collect()
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

/// Publishes the requests of every kind the bag holds on its topic (`grasp_candidates`,
/// `grasp_candidate_sets`, `pose_candidates`, `pose_candidate_sets`, all remappable), in the
/// order and at the pace they were received (their `log_time`): waits for a subscriber on each
/// topic with something to send, keeps the recorded gaps, stops early on SIGINT or SIGTERM.
pub(crate) fn publish(
    session: &mut Session,
    source: &Path,
    bag: &Bag,
    pace: Pace,
) -> anyhow::Result<Played> {
    struct Topics<'a>(&'a Session, [String; kind::COUNT]);
    impl Visit for Topics<'_> {
        fn kind<K: Kind>(&mut self) {
            self.1[K::INDEX] = self.0.topic_name(K::TOPICS[0]);
        }
    }
    let mut topics = Topics(session, Default::default());
    kind::each(&mut topics);
    let topics = topics.1;
    let players = players(session, &topics, pace.depth)?;
    let items = merged(bag);
    let result: anyhow::Result<Played> = session.run(async |node, shutdown| {
        let mut played = Played {
            sent: [0; kind::COUNT],
            topics: topics.clone(),
        };
        let waits = waits(&players, node, bag, &topics);
        if !wait_for_subscribers(shutdown, waits, pace.wait).await? {
            return Ok(played);
        }
        // The kinds it holds, and their topics.
        let (what, on): (Vec<String>, Vec<&str>) = bag
            .streams
            .request_counts()
            .iter()
            .zip(kind::plurals())
            .zip(&topics)
            .filter(|((n, _), _)| **n > 0)
            .map(|((n, name), topic)| (format!("{n} {name}"), topic.as_str()))
            .unzip();
        log::info!(
            "playing {} from {} on {}",
            what.join(", "),
            source.display(),
            on.join(", ")
        );
        let start = Instant::now();
        let first = items.first().map_or(0, |(t, _, _)| *t);
        for &(time, kind, index) in &items {
            if pace.rate > 0.0 {
                let offset = time.saturating_sub(first) as f64 / 1e9 / pace.rate;
                if !paced(start, offset, shutdown).await {
                    break;
                }
            }
            if let Some(player) = players.get(kind) {
                player.send(bag, index).await?;
                played.sent[kind] += 1;
            }
        }
        let sent: usize = played.sent.iter().sum();
        log::debug!("sent {sent} of {} messages", items.len());
        // Let reliable delivery finish before leaving.
        smol::Timer::after(Duration::from_millis(500)).await;
        Ok(played)
    });
    drop(players);
    result
}
