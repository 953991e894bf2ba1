//! The node's `/tf` and `/tf_static` subscriptions, and their messages drained into a
//! [`TfBuffer`] without blocking.
//!
//! The QoS are tf2_ros's listener's (geometry2, Jazzy, `tf2_ros/include/tf2_ros/qos.hpp`):
//! `DynamicListenerQoS` is rclcpp's default, reliable, volatile, keep-last 100;
//! `StaticListenerQoS` the same but transient-local, so that a node started after a static
//! broadcaster still receives the static transforms it latched.

use super::session::create_topic;
use crate::msg::TfMessage;
use crate::tf::TfBuffer;
use ros2_client::qos::{Durability, History};
use ros2_client::{Node, QosProfile, Subscription};

/// The dynamic transforms' topic, as tf2_ros names it (before remapping).
pub(crate) const TF_TOPIC: &str = "/tf";
/// The static transforms' topic, as tf2_ros names it (before remapping).
pub(crate) const TF_STATIC_TOPIC: &str = "/tf_static";
/// tf2_ros's listener depth, both topics.
const DEPTH: usize = 100;
/// The most messages one [`TfListener::drain`] takes from each topic, so that a flood cannot
/// hold the node's thread; the rest wait for the next drain.
pub(crate) const MAX_MESSAGES_PER_DRAIN: usize = 1000;

/// The QoS of `/tf`: reliable, volatile, keep-last 100.
pub(crate) fn dynamic_qos() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: DEPTH })
}

/// The QoS of `/tf_static`: reliable, transient-local, keep-last 100.
pub(crate) fn static_qos() -> QosProfile {
    dynamic_qos().durability(Durability::TransientLocal)
}

/// The two subscriptions.
pub(crate) struct TfListener {
    /// `/tf`.
    pub(crate) dynamic: Subscription<TfMessage>,
    /// `/tf_static`.
    pub(crate) fixed: Subscription<TfMessage>,
}

/// What one drain took.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Drained {
    /// Messages from `/tf`.
    pub(crate) dynamic: usize,
    /// Messages from `/tf_static`.
    pub(crate) fixed: usize,
    /// Messages that could not be read (undecodable), both topics.
    pub(crate) unreadable: usize,
}

impl TfListener {
    /// Subscribes to the full names `tf` and `tf_static`: [`TF_TOPIC`] and [`TF_STATIC_TOPIC`]
    /// (absolute: TF is global, whatever the node's namespace, as with tf2_ros), or what a
    /// remap makes of them (`-r /tf:=/robot1/tf`, as multi-robot stacks do).
    pub(crate) fn create(node: &mut Node, tf: &str, tf_static: &str) -> anyhow::Result<Self> {
        let dynamic_topic = create_topic::<TfMessage>(node, tf, &dynamic_qos())?;
        let static_topic = create_topic::<TfMessage>(node, tf_static, &static_qos())?;
        let dynamic = node
            .create_subscription(&dynamic_topic, Some(dynamic_qos()))
            .map_err(|e| anyhow::anyhow!("cannot subscribe to {tf}: {e:?}"))?;
        let fixed = node
            .create_subscription(&static_topic, Some(static_qos()))
            .map_err(|e| anyhow::anyhow!("cannot subscribe to {tf_static}: {e:?}"))?;
        Ok(Self { dynamic, fixed })
    }

    /// Takes what has arrived on both topics, up to [`MAX_MESSAGES_PER_DRAIN`] each, into
    /// `buffer` (`/tf_static` first); never waits.
    pub(crate) fn drain(&self, buffer: &mut TfBuffer) -> Drained {
        let mut drained = Drained::default();
        let (n, bad) = drain_one(&self.fixed, buffer, true);
        drained.fixed = n;
        drained.unreadable += bad;
        let (n, bad) = drain_one(&self.dynamic, buffer, false);
        drained.dynamic = n;
        drained.unreadable += bad;
        drained
    }
}

/// Up to [`MAX_MESSAGES_PER_DRAIN`] messages of one subscription into `buffer`: how many were
/// kept and how many could not be read.
fn drain_one(
    sub: &Subscription<TfMessage>,
    buffer: &mut TfBuffer,
    is_static: bool,
) -> (usize, usize) {
    let (mut kept, mut bad) = (0, 0);
    for _ in 0..MAX_MESSAGES_PER_DRAIN {
        match sub.take() {
            Ok(Some((message, _info))) => {
                buffer.insert_message(&message, is_static);
                kept += 1;
            }
            Ok(None) => break,
            // A sample that does not decode as a TFMessage: skipped, counted.
            Err(_) => bad += 1,
        }
    }
    (kept, bad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ros2_client::qos::Reliability;

    /// tf2_ros's listener QoS: both reliable, keep-last 100; only /tf_static transient-local.
    #[test]
    fn the_qos_are_tf2_ros_listeners() {
        for q in [dynamic_qos(), static_qos()] {
            assert!(matches!(q.reliability, Reliability::Reliable { .. }));
            assert_eq!(q.history, History::KeepLast { depth: 100 });
        }
        assert_eq!(dynamic_qos().durability, Durability::Volatile);
        assert_eq!(static_qos().durability, Durability::TransientLocal);
    }
}
