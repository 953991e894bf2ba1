//! The node's `/tf` and `/tf_static` subscriptions, and their messages drained into a
//! [`TfBuffer`] without blocking.
//!
//! The QoS are tf2_ros's listener's (geometry2, Jazzy, `tf2_ros/include/tf2_ros/qos.hpp`):
//! `DynamicListenerQoS` is rclcpp's default, reliable, volatile, keep-last 100;
//! `StaticListenerQoS` the same but transient-local, so that a node started after a static
//! broadcaster still receives the static transforms it latched.

// The answering loop does not drain these yet: until it does, they are unused.
#![allow(dead_code)]

use super::session::create_topic;
use crate::msg::TfMessage;
use crate::tf::TfBuffer;
use ros2_client::qos::{Durability, History};
use ros2_client::{Node, QosProfile, Subscription};
use std::time::{Duration, Instant};

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
    dynamic: Subscription<TfMessage>,
    fixed: Subscription<TfMessage>,
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

/// How often [`resolve`] looks again while it waits.
const POLL: Duration = Duration::from_millis(2);

/// `f` on the buffer, waiting up to `timeout` for the transforms it needs, as tf2_ros's
/// `lookupTransform` with a timeout: `drain` (for the node, [`TfListener::drain`]) brings in what
/// has arrived, then `f` is tried; on failure, again every [`POLL`] until `timeout` has passed
/// since the start, and then the last failure is the answer. With `timeout` zero, one try.
pub(crate) async fn resolve<T, E>(
    buffer: &mut TfBuffer,
    mut drain: impl FnMut(&mut TfBuffer),
    timeout: Duration,
    f: impl Fn(&TfBuffer) -> Result<T, E>,
) -> Result<T, E> {
    let deadline = Instant::now() + timeout;
    loop {
        drain(buffer);
        let result = f(buffer);
        let now = Instant::now();
        if result.is_ok() || now >= deadline {
            return result;
        }
        smol::Timer::at((now + POLL).min(deadline)).await;
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
    use crate::msg::{Header, Time, TransformStamped};
    use crate::tf::{gravity_in, TfFailure};
    use ros2_client::qos::Reliability;

    fn header(frame: &str) -> Header {
        Header {
            stamp: Time { sec: 0, nanosec: 0 },
            frame_id: frame.into(),
        }
    }

    fn identity(parent: &str, child: &str) -> TransformStamped {
        let mut t = TransformStamped::default();
        t.header.frame_id = parent.into();
        t.child_frame_id = child.into();
        t.transform.rotation.w = 1.0;
        t
    }

    fn gravity(b: &TfBuffer) -> Result<nalgebra::Vector3<f64>, TfFailure> {
        gravity_in(b, "world", [0.0, 0.0, -9.8], &header("tool")).expect("gravity_frame set")
    }

    /// A transform that arrives while the candidate waits answers it; one that never comes
    /// gives tf2's error once the timeout has passed, not before.
    #[test]
    fn resolve_waits_for_the_transform_up_to_the_timeout() {
        let mut buffer = TfBuffer::new();
        let mut drains = 0;
        let start = Instant::now();
        let g = smol::block_on(resolve(
            &mut buffer,
            |b| {
                drains += 1;
                if drains == 5 {
                    b.insert(&identity("world", "tool"), true);
                }
            },
            Duration::from_secs(5),
            gravity,
        ))
        .expect("arrived on the fifth drain");
        assert_eq!(g, nalgebra::Vector3::new(0.0, 0.0, -9.8));
        assert_eq!(drains, 5);
        assert!(start.elapsed() < Duration::from_secs(4));

        let mut buffer = TfBuffer::new();
        let start = Instant::now();
        let e = smol::block_on(resolve(
            &mut buffer,
            |_| {},
            Duration::from_millis(50),
            gravity,
        ))
        .expect_err("never arrives");
        assert!(start.elapsed() >= Duration::from_millis(50));
        assert!(
            e.to_string().contains(
                "\"tool\" passed to lookupTransform argument target_frame does not exist"
            ),
            "{e}"
        );
        // Timeout zero: one try.
        let mut tries = 0;
        let _ = smol::block_on(resolve(
            &mut buffer,
            |_| tries += 1,
            Duration::ZERO,
            gravity,
        ));
        assert_eq!(tries, 1);
    }

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
