//! A kind's two topics on the node: its requests subscribed, its answers published
//! ([`Endpoint`]), made alike for every kind from the recording's topic names.

use super::session::create_topic;
use crate::kind::Kind;
use crate::record::Topics;
use anyhow::Context;
use ros2_client::{Node, Publisher, QosProfile, Subscription};
use std::sync::Arc;

/// The requests of kind `K` the node takes, and the publisher of its answers.
pub(crate) struct Endpoint<K: Kind> {
    /// Its requests' topic (shared with the thread that reads it, for the kinds read off the
    /// node's thread: `intake.rs`).
    pub(crate) requests: Arc<Subscription<K::Request>>,
    /// Its answers' topic.
    pub(crate) answers: Publisher<K::Answer>,
}

impl<K: Kind> std::fmt::Debug for Endpoint<K> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Endpoint")
    }
}

impl<K: Kind> Endpoint<K> {
    /// Subscribes to `K`'s requests and publishes its answers on their topics in `topics`, with
    /// `qos`.
    pub(crate) fn create(
        node: &mut Node,
        topics: &Topics,
        qos: &QosProfile,
    ) -> anyhow::Result<Self> {
        let asked = topics.requests::<K>().unwrap_or_default();
        let answered = topics.answers::<K>().unwrap_or_default();
        let requests = create_topic::<K::Request>(node, asked, qos)?;
        let answers = create_topic::<K::Answer>(node, answered, qos)?;
        Ok(Self {
            requests: Arc::new(
                node.create_subscription(&requests, None)
                    .with_context(|| format!("cannot subscribe to {} on {asked}", K::PLURAL))?,
            ),
            answers: node
                .create_publisher(&answers, None)
                .with_context(|| format!("cannot publish answers on {answered}"))?,
        })
    }
}
