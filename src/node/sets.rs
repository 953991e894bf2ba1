//! The node's set endpoints: `grasp_candidate_sets` in, `grip_recommendation_sets` out (the same QoS
//! as the other topics), and the service `~/recommend` (`grasp_orient/srv/Recommend`), served
//! through ros2-client; and the same for sets of gripper poses: `pose_candidate_sets` in,
//! `pose_recommendation_sets` out, the service `~/recommend_poses`
//! (`grasp_orient/srv/RecommendPoses`). Each set is handed to the set thread ([`SetWorker::submit`]) and the node's
//! thread goes on; when its answer is back ([`answer_done`]) it is published (or sent back to the
//! caller), then its markers, then it is counted and recorded. A set refused because the set
//! thread's queue is full is answered the same way, at once.

use super::answer::{Answerer, SetInput, SetOutcome, SetReply};
use super::markers_out::MarkersOut;
use super::session::{say, tell};
pub(crate) use super::set_kinds::NodeSet;
pub(crate) use super::set_kinds::SetEndpoints;
use super::set_kinds::{SetEndpoint, VisitSetEndpoint};
use super::set_worker::{SetDone, SetJob, SetWorker, Via};
use crate::msg::moveit::RankGraspsRequest;
use crate::msg::short_id;
use crate::record::{now_ns, Topics};
use futures::stream::{LocalBoxStream, StreamExt as _};
use ros2_client::{MessageInfo, Node, RmwRequestId};
use std::time::{Duration, Instant};

/// A set that arrived, of any set kind.
pub(crate) enum Arrival {
    /// On its topic.
    Topic(SetInput, MessageInfo),
    /// In a call of its service.
    Call(RmwRequestId, SetInput),
    /// A call of `~/rank_grasps`, to be turned into its pose set (`grasps.rs`).
    Grasps(RmwRequestId, Box<RankGraspsRequest>),
    /// A message on a set topic or service that did not decode: where, and why.
    Undecodable(String, Why),
}

/// Why a message did not decode, as its decoder said it.
pub(crate) struct Why(String);

impl std::fmt::Debug for Why {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Every set kind's sets as they arrive, on its topic and in calls of its service, as one stream.
pub(crate) fn arrivals<'a>(
    endpoints: &'a SetEndpoints,
    topics: &'a Topics,
) -> impl futures::Stream<Item = Arrival> + 'a {
    struct Collect<'a> {
        topics: &'a Topics,
        streams: Vec<LocalBoxStream<'a, Arrival>>,
    }
    impl<'a> VisitSetEndpoint<'a> for Collect<'a> {
        fn endpoint<K: NodeSet>(&mut self, endpoint: &'a SetEndpoint<K>) {
            let topic = self.topics.requests::<K>().unwrap_or_default().to_string();
            self.streams.push(
                endpoint
                    .topic
                    .requests
                    .async_stream()
                    .map(move |received| match received {
                        Ok((set, info)) => Arrival::Topic(SetInput::new::<K>(set), info),
                        Err(e) => Arrival::Undecodable(topic.clone(), Why(format!("{e:?}"))),
                    })
                    .boxed_local(),
            );
            self.streams.push(
                endpoint
                    .service
                    .receive_request_stream()
                    .map(|call| match call {
                        Ok((id, request)) => {
                            Arrival::Call(id, SetInput::new::<K>(K::from_call(request)))
                        }
                        Err(e) => {
                            Arrival::Undecodable(K::SERVICE.to_string(), Why(format!("{e:?}")))
                        }
                    })
                    .boxed_local(),
            );
        }
    }
    let mut collect = Collect {
        topics,
        streams: Vec::new(),
    };
    endpoints.each(&mut collect);
    collect.streams.push(
        endpoints
            .grasps
            .server
            .receive_request_stream()
            .map(|call| match call {
                Ok((id, request)) => Arrival::Grasps(id, Box::new(request)),
                Err(e) => {
                    Arrival::Undecodable(super::grasps::SERVICE.into(), Why(format!("{e:?}")))
                }
            })
            .boxed_local(),
    );
    futures::stream::select_all(collect.streams)
}

/// Takes one set (of candidates or of poses) from its topic: hands it to the set thread, or
/// answers it at once when the set thread's queue is full.
pub(crate) async fn take_topic(
    node: &Node,
    endpoints: &SetEndpoints,
    markers: &MarkersOut,
    answerer: &mut Answerer,
    worker: &SetWorker,
    set: SetInput,
    (received, sent): (u64, u64),
) {
    // From the sample's arrival in the DDS reader (the last fragment) to here: the node's
    // thread waking, and the set decoded.
    let taken = Duration::from_nanos(now_ns().saturating_sub(received));
    let (record, record_markers) = answerer.records_sets();
    let job = SetJob {
        set,
        received,
        sent,
        via: Via::Topic { taken },
        record,
        record_markers,
        audience: markers.heard(node),
    };
    if let Err(done) = worker.submit(job) {
        answer_done(node, endpoints, markers, answerer, *done).await;
    }
}

/// Takes one call of `~/recommend` or `~/recommend_poses` (its times are when it was taken,
/// `received`), as [`take_topic`] does.
pub(crate) async fn take_call(
    node: &Node,
    endpoints: &SetEndpoints,
    markers: &MarkersOut,
    answerer: &mut Answerer,
    worker: &SetWorker,
    (via, set): (Via, SetInput),
    received: u64,
) {
    let (record, record_markers) = answerer.records_sets();
    let job = SetJob {
        set,
        received,
        sent: received,
        via,
        record,
        record_markers,
        audience: markers.heard(node),
    };
    if let Err(done) = worker.submit(job) {
        answer_done(node, endpoints, markers, answerer, *done).await;
    }
}

/// Sends a set's answer where the set came from (published, or the response to its call); then
/// its markers; then counts and records it.
pub(crate) async fn answer_done(
    node: &Node,
    endpoints: &SetEndpoints,
    markers: &MarkersOut,
    answerer: &mut Answerer,
    done: SetDone,
) {
    let SetDone {
        via,
        outcome,
        waited,
        took,
    } = done;
    let SetOutcome {
        reply,
        markers: array,
        recorded,
    } = outcome;
    tell(node, answerer.count_set(&reply, array.is_some()));
    let (how, taken) = match via {
        Via::Topic { taken } => ("topic", Some(taken)),
        Via::Service(_) => ("service", None),
        Via::Grasps(_) => ("rank_grasps", None),
    };
    let line = AnswerLine::new(&reply, how, taken, took, waited);
    answerer.recent().note_all(reply.members());
    let sending = Instant::now();
    let sent = reply.send(endpoints, via).await;
    let answered = now_ns();
    line.log(sending.elapsed(), sent.is_ok(), answered);
    if let Err(e) = sent {
        say(node, log::Level::Error, &e);
    }
    markers.publish(node, answerer, array).await;
    tell(node, answerer.record_set(recorded, answered));
}

/// One line at debug per set answered, as for single candidates, written once the answer is out:
/// where the set's time in the node went. `taken`: from the set's arrival in the DDS reader to
/// the node's thread taking it (the thread waking, and the set decoded; topic only);
/// `answered in`: solving on the set thread, ranking, the best candidate's markers and the
/// recording's copy; `published in`: serializing the answer and handing it to DDS, and freeing
/// it; `waited`: from the hand-over to the set thread to the start of its solving (the thread
/// waking, and the sets before it in the queue). `taken` also holds any wait behind the
/// previous message, and is 0 when DDS gave no arrival time. A published answer's line ends with
/// the time publishing returned (the answer handed to DDS, and freed), in ns since the epoch on
/// the system clock (the clock of DDS's own timestamps), so that a client on the same machine can
/// tell the node's time from the transport's.
/// `benches/bench_sets.py` reads these lines.
struct AnswerLine {
    /// The line up to the publishing time, and the wait for the set thread; none when debug
    /// lines are off.
    text: Option<(String, Duration)>,
}

impl AnswerLine {
    fn new(
        reply: &SetReply,
        via: &str,
        taken: Option<Duration>,
        took: Duration,
        waited: Duration,
    ) -> Self {
        if !log::log_enabled!(log::Level::Debug) {
            return Self { text: None };
        }
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let taken = taken.map_or(String::new(), |t| {
            format!(", taken {:.3} ms after it arrived", ms(t))
        });
        Self {
            text: Some((
                format!(
                    "set {:?} ({via}): {} candidates, {} ranked by {}, status {}{taken}, answered \
                     in {:.3} ms",
                    short_id(reply.set_id()),
                    reply.members().len(),
                    reply.ranked().0,
                    reply.ranked().1,
                    reply.status(),
                    ms(took)
                ),
                waited,
            )),
        }
    }

    fn log(self, sending: Duration, sent: bool, handed_ns: u64) {
        if let Some((text, waited)) = self.text {
            let (how, handed) = if sent {
                ("published in", format!("; handed to DDS at {handed_ns} ns"))
            } else {
                ("not published, after", String::new())
            };
            log::debug!(
                "{text}, {how} {:.3} ms; it waited {:.3} ms for the set thread{handed}",
                sending.as_secs_f64() * 1e3,
                waited.as_secs_f64() * 1e3
            );
        }
    }
}
