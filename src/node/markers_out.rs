//! The `grip_markers` publisher, and whether anybody takes what it would publish.
//!
//! A marker array per answer (built, serialized, handed to DDS) costs the node's thread about as
//! much as the answer itself; published to no subscriber it is seen by nobody, since the topic is
//! volatile (no history kept for a subscriber that comes later). So markers are built only when
//! `grip_markers` has a matched subscriber or the recording takes them (`record_markers`), and
//! published only in the first case ([`super::answer::Answerer::draws`]).

use super::answer::Answerer;
use crate::msg::MarkerArray;
use futures::FutureExt as _;
use ros2_client::{Node, Publisher};
use std::cell::Cell;
use std::pin::pin;
use std::time::Duration;

/// How often [`MarkersOut::watch`] looks up the match table itself, in case the event of the
/// first match was dropped.
const RECHECK: Duration = Duration::from_secs(1);

/// The `grip_markers` publisher and what the node knows of its subscribers.
pub(crate) struct MarkersOut {
    publisher: Publisher<MarkerArray>,
    /// Whether a subscriber has ever been matched ([`MarkersOut::watch`]).
    matched: Cell<bool>,
}

impl MarkersOut {
    /// The publisher, with no subscriber matched yet.
    pub(crate) fn new(publisher: Publisher<MarkerArray>) -> Self {
        Self {
            publisher,
            matched: Cell::new(false),
        }
    }

    /// Whether `grip_markers` has a matched subscriber now. Asked for every answer (a lookup in
    /// ros2-client's table of the readers matched to each writer, which its spinner keeps up to
    /// date from DDS), so that a subscriber that comes late gets markers from the node's next
    /// answer on, and one that leaves stops them. ros2-client logs an error when asked about a
    /// writer that has never been matched, hence [`MarkersOut::watch`] first.
    pub(crate) fn heard(&self, node: &Node) -> bool {
        self.matched.get() && self.publisher.get_subscription_count(node) > 0
    }

    /// Waits for the first subscriber ever matched, then returns. Runs as a task beside the
    /// answering loop.
    ///
    /// ros2-client wakes a waiting writer for every subscription matched in the node, and the
    /// writer then looks itself up in the match table. Those wake-ups travel through a channel of
    /// 8 graph events that drops what does not fit, so the event of this writer's match can be
    /// lost behind others that name no subscription (publishers matched, participants' entity
    /// lists). The wait is therefore started afresh every [`RECHECK`]: a new wait looks the table
    /// up first, without ros2-client's error for a writer never matched.
    pub(crate) async fn watch(&self, node: &Node) {
        loop {
            let mut matched = pin!(self.publisher.wait_for_subscription(node).fuse());
            let mut recheck = pin!(smol::Timer::after(RECHECK).fuse());
            futures::select! {
                () = matched => break,
                _ = recheck => {}
            }
        }
        self.matched.set(true);
    }

    /// Publishes `markers` if `grip_markers` has a subscriber now (they may have been built for
    /// the recording alone), and counts what was published.
    pub(crate) async fn publish(
        &self,
        node: &Node,
        answerer: &mut Answerer,
        markers: Option<MarkerArray>,
    ) {
        let Some(array) = markers.filter(|_| self.heard(node)) else {
            return;
        };
        match self.publisher.async_publish(array).await {
            Ok(()) => answerer.count_published_markers(),
            Err(e) => log::warn!("cannot publish markers: {e:?}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{MarkersOut, RECHECK};
    use crate::msg::{GraspCandidate, MarkerArray};
    use crate::node::session::{create_topic, qos, Graph, Session};
    use futures::FutureExt as _;
    use ros2_client::{Node, NodeOptions, Publisher, Subscription};
    use std::pin::{pin, Pin};
    use std::task::{Context, Poll};
    use std::time::{Duration, Instant};

    /// More publishers matched than ros2-client's channel of graph events holds (8).
    const FLOOD: usize = 12;

    fn session(domain: u16, name: &str) -> Session {
        let options = NodeOptions::new()
            .enable_rosout(false)
            .start_parameter_services(false);
        Session::open_helper(Graph::localhost(domain), "/", name, options).expect("session")
    }

    fn flood_topic(k: usize) -> String {
        format!("/markers_watch_flood_{k}")
    }

    /// Lets the spinner run until `done` holds, for at most `limit`.
    async fn until(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
        let start = Instant::now();
        while !done() {
            if start.elapsed() > limit {
                return false;
            }
            smol::Timer::after(Duration::from_millis(20)).await;
        }
        true
    }

    fn poll_once<F: std::future::Future>(f: Pin<&mut F>) -> Poll<F::Output> {
        f.poll(&mut Context::from_waker(std::task::Waker::noop()))
    }

    /// The first `grip_markers` subscriber's match event is dropped (the channel is full of
    /// publishers' matches when it comes): the watch still sees the match, within a recheck.
    #[test]
    fn a_match_whose_event_was_dropped_is_still_seen() {
        let domain = 210 + u16::try_from(std::process::id() % 20).expect("small");
        let mut ours = session(domain, "markers_watch_test");
        let mut theirs = session(domain, "markers_watch_peer");
        let markers =
            create_topic::<MarkerArray>(ours.node(), "/markers_watch", &qos(10)).expect("topic");
        let publisher: Publisher<MarkerArray> = ours
            .node_mut()
            .create_publisher(&markers, None)
            .expect("publisher");
        let readers: Vec<Subscription<GraspCandidate>> = (0..FLOOD)
            .map(|k| {
                let topic = create_topic::<GraspCandidate>(ours.node(), &flood_topic(k), &qos(10))
                    .expect("topic");
                ours.node_mut()
                    .create_subscription(&topic, None)
                    .expect("subscription")
            })
            .collect();
        let markers_out = MarkersOut::new(publisher);
        let seen = ours.run(async |node, _| {
            let node: &Node = node;
            let mut watch = pin!(markers_out.watch(node).fuse());
            // Drain what the two participants' discovery says at first, then stop listening.
            until(Duration::from_secs(2), || {
                assert!(
                    poll_once(watch.as_mut()).is_pending(),
                    "nobody subscribes yet"
                );
                false
            })
            .await;
            let flood: Vec<Publisher<GraspCandidate>> = (0..FLOOD)
                .map(|k| {
                    let topic =
                        create_topic::<GraspCandidate>(theirs.node(), &flood_topic(k), &qos(10))
                            .expect("topic");
                    theirs
                        .node_mut()
                        .create_publisher(&topic, None)
                        .expect("publisher")
                })
                .collect();
            let all_matched = || readers.iter().all(|r| r.get_publisher_count(node) > 0);
            assert!(until(Duration::from_secs(20), all_matched).await);
            let topic = create_topic::<MarkerArray>(theirs.node(), "/markers_watch", &qos(10))
                .expect("topic");
            let subscriber: Subscription<MarkerArray> = theirs
                .node_mut()
                .create_subscription(&topic, None)
                .expect("subscription");
            let matched = || markers_out.publisher.get_subscription_count(node) > 0;
            assert!(until(Duration::from_secs(20), matched).await);
            let mut limit = pin!(smol::Timer::after(RECHECK * 3).fuse());
            let seen = futures::select! {
                () = watch => true,
                _ = limit => false,
            };
            drop((flood, subscriber));
            seen
        });
        drop((markers_out, readers));
        theirs.close();
        ours.close();
        assert!(seen, "the first subscriber's match was never seen");
    }
}
