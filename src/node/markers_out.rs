//! The `grip_markers` publisher, and whether anybody takes what it would publish.
//!
//! A marker array per answer (built, serialized, handed to DDS) costs the node's thread about as
//! much as the answer itself; published to no subscriber it is seen by nobody, since the topic is
//! volatile (no history kept for a subscriber that comes later). So markers are built only when
//! `grip_markers` has a matched subscriber or the recording takes them (`record_markers`), and
//! published only in the first case ([`super::answer::Answerer::draws`]).

use super::answer::Answerer;
use crate::msg::MarkerArray;
use ros2_client::{Node, Publisher};
use std::cell::Cell;

/// The `grip_markers` publisher and what the node knows of its subscribers.
pub struct MarkersOut {
    publisher: Publisher<MarkerArray>,
    /// Whether a subscriber has ever been matched ([`MarkersOut::watch`]).
    matched: Cell<bool>,
}

impl MarkersOut {
    /// The publisher, with no subscriber matched yet.
    pub fn new(publisher: Publisher<MarkerArray>) -> Self {
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
    pub fn heard(&self, node: &Node) -> bool {
        self.matched.get() && self.publisher.get_subscription_count(node) > 0
    }

    /// Waits for the first subscriber ever matched (ros2-client wakes this for every
    /// subscription matched in the node and then looks this writer up), then returns. Runs as a
    /// task beside the answering loop.
    pub async fn watch(&self, node: &Node) {
        self.publisher.wait_for_subscription(node).await;
        self.matched.set(true);
    }

    /// Publishes `markers` if `grip_markers` has a subscriber now (they may have been built for
    /// the recording alone), and counts what was published.
    pub async fn publish(
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
