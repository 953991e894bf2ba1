//! The node's endpoints, what its answering loop holds, and the way one candidate or pose
//! candidate is answered and its answer sent: what the loop (`mod.rs`) and the TF gate
//! (`tf_serve.rs`) both call.

use super::answer::{self, Answerer};
use super::endpoint::Endpoint;
use super::loads::{Loaded, PoseLoads};
use super::markers_out::MarkersOut;
use super::scene::{self, Scene, SceneListener};
use super::session::{create_topic, qos, say, tell, Session};
use super::set_worker::SetWorker;
use super::sets::SetEndpoints;
use super::tf;
use super::tf_wait::TfWait;
use crate::kind::{Candidates, Poses};
use crate::msg::{
    short_id, GraspCandidate, GripRecommendation, MarkerArray, PoseCandidate, PoseRecommendation,
};
use crate::record::{now_ns, Topics};
use crate::tf::ToolFrame;
use anyhow::Context as _;
use ros2_client::Node;

/// The node's topics and their endpoints.
pub(super) struct Endpoints {
    pub(super) topics: Topics,
    pub(super) candidates: Endpoint<Candidates>,
    pub(super) markers: MarkersOut,
    /// Shared with the thread that reads the sets (`intake.rs`).
    pub(super) sets: std::sync::Arc<SetEndpoints>,
    pub(super) poses: Endpoint<Poses>,
    /// `/tf` and `/tf_static`.
    pub(super) tf: tf::TfListener,
    /// `/collision_object` and `/planning_scene`.
    pub(super) moveit: SceneListener,
}

impl Endpoints {
    pub(super) fn create(session: &mut Session, qos_depth: i64) -> anyhow::Result<Self> {
        let qos = qos(qos_depth);
        let topics = Topics::named(|base| session.topic_name(base))
            .with_markers(session.topic_name("grip_markers"));
        let markers_name = topics.markers.clone().unwrap_or_default();
        let tf_name = session.topic_name(tf::TF_TOPIC);
        let tf_static_name = session.topic_name(tf::TF_STATIC_TOPIC);
        let objects_name = session.topic_name(scene::COLLISION_OBJECT_TOPIC);
        let scenes_name = session.topic_name(scene::PLANNING_SCENE_TOPIC);
        let node = session.node_mut();
        let markers = create_topic::<MarkerArray>(node, &markers_name, &qos)?;
        Ok(Self {
            candidates: Endpoint::create(node, &topics, &qos)?,
            sets: std::sync::Arc::new(SetEndpoints::create(node, &topics, qos_depth)?),
            poses: Endpoint::create(node, &topics, &qos)?,
            tf: tf::TfListener::create(node, &tf_name, &tf_static_name)?,
            moveit: SceneListener::create(node, &objects_name, &scenes_name, &qos)?,
            markers: MarkersOut::new(
                node.create_publisher(&markers, None)
                    .context("cannot publish markers")?,
            ),
            topics,
        })
    }
}

/// What the answering loop changes: the answerer, the set thread, what wakes the loop, the pose
/// candidates loading their meshes and the requests waiting for transforms.
pub(super) struct Loop<'a> {
    pub(super) answerer: &'a mut Answerer,
    pub(super) worker: &'a mut SetWorker,
    pub(super) woken: &'a mut futures::channel::mpsc::UnboundedReceiver<()>,
    pub(super) loading: &'a mut Loading,
    pub(super) tf: &'a mut TfWait,
    /// The objects learned from MoveIt, and the table of their mass and friction.
    pub(super) scene: &'a mut Scene,
}

/// Single pose candidates answered off the node's thread because their mesh was not loaded yet
/// or is a large inline mesh ([`super::loads`]).
pub(super) type Loading = PoseLoads;

/// Answers one candidate: the answer goes out first; markers and the recording follow it.
pub(super) async fn answer_one(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    candidate: GraspCandidate,
    (received, sent): (u64, u64),
) {
    let audience = endpoints.markers.heard(node);
    let outcome = answerer.handle(candidate, received, sent, audience);
    let answers = &endpoints.candidates.answers;
    send_answer(node, endpoints, answerer, answers, outcome).await;
}

/// Takes one pose candidate: answered on the node's thread when its mesh is loaded already, or
/// it names none and carries no inline mesh of [`answer::INLINE_OFF_THREAD_TRIANGLES`] triangles
/// or more, or it is refused before any load (an inline mesh beyond `max_inline_mesh_triangles`);
/// otherwise on a loader thread ([`super::loads`]), its answer sent when it is back or when
/// `max_mesh_load_time` has passed, so that a first load or a large inline mesh's index (a tenth
/// of a second and more for 100,000 triangles) holds up no other topic, and a load that never
/// ends holds up nothing. Never on the node's thread: with every loader busy the candidate
/// waits, and with the queue full it is refused at once. Answers may then come back in another
/// order than their candidates. Its answer's tool pose goes into `tool_frame` (`gravity_frame`,
/// by the transform looked up when the candidate was turned by TF), if any.
pub(super) async fn take_pose(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    loading: &mut Loading,
    (candidate, tool_frame): (PoseCandidate, Option<ToolFrame>),
    (received, sent): (u64, u64),
) {
    let audience = endpoints.markers.heard(node);
    let work = answerer
        .pose_work(received, audience)
        .with_tool_frame(tool_frame);
    if work.refusal(&candidate).is_none() && answerer.answers_off_thread(&candidate) {
        if let Err(refused) = loading.take(work, candidate, received, sent) {
            send_loaded(node, endpoints, answerer, *refused).await;
        }
        return;
    }
    let (reply, markers) = work.run(&candidate);
    let outcome = answerer.account_pose(candidate, reply, markers, received, sent);
    send_answer(node, endpoints, answerer, &endpoints.poses.answers, outcome).await;
}

/// Counts, sends and records a pose candidate answered off the node's thread.
pub(super) async fn send_loaded(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    l: Loaded,
) {
    let outcome = answerer.account_pose(l.candidate, l.reply, l.markers, l.received, l.sent);
    send_answer(node, endpoints, answerer, &endpoints.poses.answers, outcome).await;
}

/// An answer to one candidate or pose candidate, as its log line names it.
pub(super) trait Recommends {
    /// What it answers, for the log: "candidate", "pose candidate".
    const WHAT: &'static str;
    /// Its recommendation (a pose answer's is inside it).
    fn recommendation(&self) -> &GripRecommendation;
}

impl Recommends for GripRecommendation {
    const WHAT: &'static str = "candidate";
    fn recommendation(&self) -> &GripRecommendation {
        self
    }
}

impl Recommends for PoseRecommendation {
    const WHAT: &'static str = "pose candidate";
    fn recommendation(&self) -> &GripRecommendation {
        &self.recommendation
    }
}

/// Sends one answer on `answers`: the answer goes out first; its markers, then the recording,
/// follow it.
pub(super) async fn send_answer<A: Recommends + serde::Serialize + std::fmt::Debug>(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    answers: &ros2_client::Publisher<A>,
    outcome: answer::Outcome<A>,
) {
    let r = outcome.reply.recommendation();
    log::debug!(
        "{} {:?}: status {}, gravity angle {}, {} {} N",
        A::WHAT,
        short_id(&r.candidate_id),
        r.status,
        r.gravity_angle,
        r.objective,
        r.gripping_power
    );
    tell(node, outcome.notes);
    answerer.recent().note(r);
    if let Err(e) = answers.async_publish(outcome.reply).await {
        let why = format!("cannot publish the answer to a {}: {e:?}", A::WHAT);
        say(node, log::Level::Error, &why);
    }
    markers_then_record(node, endpoints, answerer, outcome.markers, outcome.recorded).await;
}

/// After an answer went out: its markers (if `grip_markers` has a subscriber: they may have been
/// built for the recording alone), then its record with the time the answer was sent.
pub(super) async fn markers_then_record(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    markers: Option<MarkerArray>,
    recorded: answer::Recorded,
) {
    let answered = now_ns();
    endpoints.markers.publish(node, answerer, markers).await;
    let notes = answerer.record(recorded, answered);
    tell(node, notes);
}
