//! The node's set endpoints: `grasp_candidate_sets` in, `grip_recommendation_sets` out (the same QoS
//! as the other topics), and the service `~/recommend` (`grasp_orient/srv/Recommend`), served
//! through ros2-client. Each set goes to [`Answerer::handle_set`]; its answer is published (or sent
//! back to the caller), then its markers, then it is recorded.

use super::answer::{Answerer, SetOutcome};
use super::session::{create_topic, qos, say, Session};
use crate::msg::{
    short_id, GraspCandidateSet, GripRecommendationSet, MarkerArray, RecommendRequest,
    RecommendResponse,
};
use crate::record::{now_ns, SetTopics};
use anyhow::Context as _;
use ros2_client::{
    MessageInfo, Name, Node, Publisher, RmwRequestId, Server, ServiceMapping, ServiceTypeName,
    Subscription,
};
use std::time::{Duration, Instant};

/// The service's name under the node (`~/recommend`).
pub const SERVICE: &str = "recommend";

/// The set topics and the service.
pub struct SetEndpoints {
    /// `grasp_candidate_sets`.
    pub candidates: Subscription<GraspCandidateSet>,
    /// `grip_recommendation_sets`.
    pub answers: Publisher<GripRecommendationSet>,
    /// `~/recommend`.
    pub service: Server<RecommendRequest, RecommendResponse>,
}

impl std::fmt::Debug for SetEndpoints {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SetEndpoints")
    }
}

impl SetEndpoints {
    /// The topic names (after namespace and remapping).
    pub fn topics(session: &Session) -> SetTopics {
        SetTopics {
            candidates: session.topic_name("grasp_candidate_sets"),
            recommendations: session.topic_name("grip_recommendation_sets"),
        }
    }

    /// Creates the endpoints on `topics` with QoS depth `qos_depth`.
    pub fn create(node: &mut Node, topics: &SetTopics, qos_depth: i64) -> anyhow::Result<Self> {
        let qos = qos(qos_depth);
        let sets = create_topic::<GraspCandidateSet>(node, &topics.candidates, &qos)?;
        let answers = create_topic::<GripRecommendationSet>(node, &topics.recommendations, &qos)?;
        let fqn = node.fully_qualified_name();
        let name = Name::new(&fqn, SERVICE)
            .map_err(|e| anyhow::anyhow!("service {fqn}/{SERVICE}: {e:?}"))?;
        let service = node
            .create_server(
                ServiceMapping::Enhanced,
                &name,
                &ServiceTypeName::new("grasp_orient", "Recommend"),
                qos.clone(),
                qos,
            )
            .with_context(|| format!("cannot offer the service {fqn}/{SERVICE}"))?;
        Ok(Self {
            candidates: node
                .create_subscription(&sets, None)
                .context("cannot subscribe to sets")?,
            answers: node
                .create_publisher(&answers, None)
                .context("cannot publish set answers")?,
            service,
        })
    }
}

/// Answers one set from the topic: the answer goes out first; markers and the recording follow.
pub async fn answer_topic(
    node: &Node,
    endpoints: &SetEndpoints,
    markers: &Publisher<MarkerArray>,
    answerer: &mut Answerer,
    set: GraspCandidateSet,
    info: &MessageInfo,
) {
    let (received, sent) = super::message_times(info);
    // From the sample's arrival in the DDS reader (the last fragment) to here: the node's
    // thread waking, and the set decoded.
    let taken = Duration::from_nanos(now_ns().saturating_sub(received));
    let started = Instant::now();
    let outcome = answerer.handle_set(set, received, sent);
    let took = started.elapsed();
    let SetOutcome {
        reply,
        markers: array,
        notes,
        recorded,
    } = outcome;
    super::tell(node, notes);
    let line = AnswerLine::new(&reply, "topic", Some(taken), took);
    let publishing = Instant::now();
    let published = endpoints.answers.async_publish(reply).await;
    line.log(publishing.elapsed(), published.is_ok());
    if let Err(e) = published {
        say(
            node,
            log::Level::Error,
            &format!("cannot publish a set answer: {e:?}"),
        );
    }
    let answered = now_ns();
    publish_markers(markers, array).await;
    super::tell(node, answerer.record_set(recorded, answered));
}

/// Answers one call of `~/recommend`: the response goes back first; markers and the recording
/// follow (the request's times are when it was taken).
pub async fn answer_call(
    node: &Node,
    endpoints: &SetEndpoints,
    markers: &Publisher<MarkerArray>,
    answerer: &mut Answerer,
    id: RmwRequestId,
    request: RecommendRequest,
) {
    let received = now_ns();
    let started = Instant::now();
    let outcome = answerer.handle_set(request.candidate_set, received, received);
    let took = started.elapsed();
    super::tell(node, outcome.notes);
    let line = AnswerLine::new(&outcome.reply, "service", None, took);
    let response = RecommendResponse {
        recommendation_set: outcome.reply,
    };
    let sending = Instant::now();
    let sent = endpoints.service.async_send_response(id, response).await;
    line.log(sending.elapsed(), sent.is_ok());
    if let Err(e) = sent {
        say(
            node,
            log::Level::Error,
            &format!("cannot send a {SERVICE} response: {e:?}"),
        );
    }
    let answered = now_ns();
    publish_markers(markers, outcome.markers).await;
    super::tell(node, answerer.record_set(outcome.recorded, answered));
}

/// One line at debug per set answered, as for single candidates, written once the answer is out:
/// where the set's time in the node went. `taken`: from the set's arrival in the DDS reader to
/// the start of its answer (the node's thread waking, and the set decoded; topic only);
/// `answered in`: solving, ranking, the best candidate's markers and the recording's copy;
/// `published in`: serializing the answer and handing it to DDS, and freeing it. `taken` also
/// holds any wait behind the previous message's markers and recording, and is 0 when DDS gave
/// no arrival time.
/// `benches/bench_sets.py` reads these lines.
struct AnswerLine {
    /// The line up to the publishing time; none when debug lines are off.
    text: Option<String>,
}

impl AnswerLine {
    fn new(
        reply: &GripRecommendationSet,
        via: &str,
        taken: Option<Duration>,
        took: Duration,
    ) -> Self {
        if !log::log_enabled!(log::Level::Debug) {
            return Self { text: None };
        }
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let taken = taken.map_or(String::new(), |t| {
            format!(", taken {:.3} ms after it arrived", ms(t))
        });
        Self {
            text: Some(format!(
                "set {:?} ({via}): {} candidates, {} ranked by {}, status {}{taken}, answered in \
                 {:.3} ms",
                short_id(&reply.set_id),
                reply.recommendations.len(),
                reply.ranking.len(),
                reply.ranked_by,
                reply.status,
                ms(took)
            )),
        }
    }

    fn log(self, sending: Duration, sent: bool) {
        if let Some(text) = self.text {
            let how = if sent {
                "published in"
            } else {
                "not published, after"
            };
            log::debug!("{text}, {how} {:.3} ms", sending.as_secs_f64() * 1e3);
        }
    }
}

async fn publish_markers(markers: &Publisher<MarkerArray>, array: Option<MarkerArray>) {
    if let Some(array) = array {
        if let Err(e) = markers.async_publish(array).await {
            log::warn!("cannot publish markers: {e:?}");
        }
    }
}
