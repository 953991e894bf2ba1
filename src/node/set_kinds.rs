//! The set kinds on the node: where a set comes from (its topic and its service), where its
//! answer goes, and how the set thread answers it ([`NodeSet`]). A candidate set is answered
//! on its candidates; a pose set first has its object made, on a loader thread when its mesh
//! must be loaded or a large inline mesh indexed, within the set's time. Everything else the
//! set thread, the hand-over and the node's loop do is the same for every set kind and goes
//! through this trait (`set_io.rs`, `set_worker.rs`, `sets.rs`).

use super::endpoint::Endpoint;
use super::grasps::GraspsService;
use super::loads::{too_slow, Loaders, LOAD_PANICKED};
use super::pose_work::INLINE_OFF_THREAD_TRIANGLES;
use super::session::qos;
use crate::answer::{answer_in_full, markers, Answering, Halt, Interrupt, Refused, SetKind};
use crate::kind::{Framing, Kind, PoseSets, Sets};
use crate::msg::{
    GraspCandidate, GraspObject, GripRecommendation, Header, MarkerArray, PoseCandidate,
    RecommendPosesRequest, RecommendPosesResponse, RecommendRequest, RecommendResponse,
};
use crate::record::Topics;
use crate::tf::ToolFrame;
use anyhow::Context as _;
use grasp_orient_geometry::{MeshCache, Object};
use ros2_client::{Message, Name, Node, Server, ServiceMapping, ServiceTypeName};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What the set thread answers a set with: the settings in force when it was received, its
/// share of the solver's threads, the interrupt its `max_set_time` raises, and the node's meshes
/// and loader threads.
pub(crate) struct Solving<'a> {
    /// The settings, rules and closing axis, on the node's meshes.
    pub(super) with: &'a Answering,
    /// The threads a large set is shared among.
    pub(super) pool: Option<&'a rayon::ThreadPool>,
    /// Raised when the set's time runs out or the node stops.
    pub(super) interrupt: &'a Interrupt,
    /// `max_set_time`, s.
    pub(super) budget: f64,
    /// Whether the best member is drawn (markers on, and a subscriber or the recording).
    pub(super) markers_on: bool,
    /// The node's meshes.
    pub(super) meshes: &'a MeshCache,
    /// The threads a pose set's mesh is loaded on.
    pub(super) loaders: &'a Loaders,
    /// `max_mesh_load_time`.
    pub(super) load_time: Duration,
}

impl Solving<'_> {
    /// Whether the best member is drawn: markers on, and not stopping.
    fn draws(&self) -> bool {
        self.markers_on && self.interrupt.halt() != Some(Halt::Stopping)
    }
}

/// A set kind as the node serves it.
pub(crate) trait NodeSet: SetKind + Framing {
    /// Its service's request and response.
    type Call: Message + Clone + 'static;
    /// Its service's response.
    type Response: Message + Clone + 'static;
    /// The service's name under the node (`~/recommend`).
    const SERVICE: &'static str;
    /// The service's type, in `grasp_orient/srv/`.
    const SERVICE_TYPE: &'static str;
    /// Its topics and service among the node's.
    fn endpoint(endpoints: &SetEndpoints) -> &SetEndpoint<Self>;
    /// The set a call asks about.
    fn from_call(call: Self::Call) -> Self::Request;
    /// The response that carries `answer`.
    fn response(answer: Self::Answer) -> Self::Response;
    /// The set's answer, solved, and its best member's markers when they are drawn (the set's
    /// clock is running, and echo mode is not on).
    fn solve(s: &Solving, set: &Self::Request) -> (Self::Answer, Option<MarkerArray>);
    /// The header whose frame the answer's tool poses are given in, for a kind that has them.
    fn tool_header(_set: &Self::Request) -> Option<&Header> {
        None
    }
    /// The answer's tool poses re-expressed by `frame` (`gravity_frame`; docs/node.md#tf).
    fn express(_answer: &mut Self::Answer, _frame: &ToolFrame) {}
    /// The answer as a pose set's, for the kind `~/rank_grasps` is answered as.
    fn pose_answer(_answer: Self::Answer) -> Option<<PoseSets as Kind>::Answer> {
        None
    }
    /// The set's object, for a kind that has one (filled from `objects_file`).
    fn object_mut(_set: &mut Self::Request) -> Option<&mut GraspObject> {
        None
    }
}

/// A set kind's topics (sets in, answers out) and its service.
pub(crate) struct SetEndpoint<K: NodeSet> {
    /// The topics.
    pub(super) topic: Endpoint<K>,
    /// The service.
    pub(super) service: Server<K::Call, K::Response>,
}

impl<K: NodeSet> SetEndpoint<K> {
    fn create(
        node: &mut Node,
        topics: &Topics,
        qos: &ros2_client::QosProfile,
    ) -> anyhow::Result<Self> {
        Ok(Self {
            topic: Endpoint::create(node, topics, qos)?,
            service: serve::<K>(node, qos)?,
        })
    }
}

/// The set kinds' endpoints.
pub(crate) struct SetEndpoints {
    /// `grasp_candidate_sets`, `grip_recommendation_sets` and `~/recommend`.
    sets: SetEndpoint<Sets>,
    /// `pose_candidate_sets`, `pose_recommendation_sets` and `~/recommend_poses`.
    pose_sets: SetEndpoint<PoseSets>,
    /// `~/rank_grasps`, answered as pose sets.
    pub(super) grasps: GraspsService,
}

impl std::fmt::Debug for SetEndpoints {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SetEndpoints")
    }
}

impl SetEndpoints {
    /// Creates the endpoints of the set kinds on `topics` with QoS depth `qos_depth`.
    pub(crate) fn create(node: &mut Node, topics: &Topics, qos_depth: i64) -> anyhow::Result<Self> {
        let qos = qos(qos_depth);
        Ok(Self {
            pose_sets: SetEndpoint::create(node, topics, &qos)?,
            sets: SetEndpoint::create(node, topics, &qos)?,
            grasps: GraspsService::offer(node, &qos)?,
        })
    }

    /// Calls `visit` with each set kind's endpoint.
    pub(crate) fn each<'a, V: VisitSetEndpoint<'a>>(&'a self, visit: &mut V) {
        visit.endpoint(&self.sets);
        visit.endpoint(&self.pose_sets);
    }
}

/// Something done with each set kind's endpoint ([`SetEndpoints::each`]).
pub(crate) trait VisitSetEndpoint<'a> {
    /// Done with `K`'s.
    fn endpoint<K: NodeSet>(&mut self, endpoint: &'a SetEndpoint<K>);
}

/// Offers the service `~/<K::SERVICE>` of type `grasp_orient/srv/<K::SERVICE_TYPE>`.
fn serve<K: NodeSet>(
    node: &mut Node,
    qos: &ros2_client::QosProfile,
) -> anyhow::Result<Server<K::Call, K::Response>> {
    let (fqn, name) = (node.fully_qualified_name(), K::SERVICE);
    let full = Name::new(&fqn, name).map_err(|e| anyhow::anyhow!("service {fqn}/{name}: {e:?}"))?;
    node.create_server(
        ServiceMapping::Enhanced,
        &full,
        &ServiceTypeName::new("grasp_orient", K::SERVICE_TYPE),
        qos.clone(),
        qos.clone(),
    )
    .with_context(|| format!("cannot offer the service {fqn}/{name}"))
}

/// Candidate sets: `~/recommend`, answered on their candidates.
impl NodeSet for Sets {
    type Call = RecommendRequest;
    type Response = RecommendResponse;
    const SERVICE: &'static str = "recommend";
    const SERVICE_TYPE: &'static str = "Recommend";
    fn endpoint(endpoints: &SetEndpoints) -> &SetEndpoint<Self> {
        &endpoints.sets
    }
    fn from_call(call: RecommendRequest) -> Self::Request {
        call.candidate_set
    }
    fn response(answer: Self::Answer) -> RecommendResponse {
        RecommendResponse {
            recommendation_set: answer,
        }
    }
    fn solve(s: &Solving, set: &Self::Request) -> (Self::Answer, Option<MarkerArray>) {
        let reply = s.with.set_within(set, s.pool, s.interrupt, s.budget);
        let best = reply.ranking.first().map(|&i| i as usize);
        let markers = best.filter(|_| s.draws()).and_then(|i| {
            let candidate = set.candidates.get(i)?;
            // A spatial best candidate is drawn in 3D: its 3D solution is solved again (one
            // candidate; the set's answers keep only the message fields).
            let spatial = (candidate.model == GraspCandidate::MODEL_SPATIAL)
                .then(|| answer_in_full(candidate, s.with.settings()).spatial)
                .flatten();
            Some(markers::build(
                &s.with.rules().tolerances.apply(candidate),
                reply.recommendations.get(i)?,
                spatial.as_deref(),
            ))
        });
        (reply, markers)
    }
}

/// Pose sets: `~/recommend_poses`, answered once their object is made (its mesh loaded here
/// when the cache does not hold it yet, within the set's time).
impl NodeSet for PoseSets {
    type Call = RecommendPosesRequest;
    type Response = RecommendPosesResponse;
    const SERVICE: &'static str = "recommend_poses";
    const SERVICE_TYPE: &'static str = "RecommendPoses";
    fn endpoint(endpoints: &SetEndpoints) -> &SetEndpoint<Self> {
        &endpoints.pose_sets
    }
    fn from_call(call: RecommendPosesRequest) -> Self::Request {
        call.pose_set
    }
    fn response(answer: Self::Answer) -> RecommendPosesResponse {
        RecommendPosesResponse {
            recommendation_set: answer,
        }
    }
    fn tool_header(set: &Self::Request) -> Option<&Header> {
        Some(&set.header)
    }
    fn express(answer: &mut Self::Answer, frame: &ToolFrame) {
        for r in &mut answer.recommendations {
            frame.express(&mut r.tool_pose);
        }
    }
    fn pose_answer(answer: Self::Answer) -> Option<Self::Answer> {
        Some(answer)
    }
    fn object_mut(set: &mut Self::Request) -> Option<&mut GraspObject> {
        Some(&mut set.object)
    }
    fn solve(s: &Solving, set: &Self::Request) -> (Self::Answer, Option<MarkerArray>) {
        let object =
            (set.poses.len() <= s.with.rules().max_set_size).then(|| object_within(s, &set.object));
        if object.as_ref().is_some_and(Result::is_err) {
            // Refused, perhaps because max_set_time ran out while it loaded: each pose says
            // why, and the set is answered whole (there is nothing left to solve).
            s.interrupt.lower_time();
        }
        // Each pose cast onto the object, then answered as a set's candidates are.
        let (reply, object) = s.with.poses().answer_set_on(set, object, |candidates| {
            s.with.set_within(candidates, s.pool, s.interrupt, s.budget)
        });
        let best = reply.ranking.first().map(|&i| i as usize);
        let markers = best.filter(|_| s.draws()).and_then(|i| {
            let pose = set.poses.get(i)?;
            let candidate = PoseCandidate {
                header: set.header.clone(),
                id: pose.id.clone(),
                grasp_pose: pose.grasp_pose.clone(),
                width: pose.width,
                object: set.object.clone(),
                gravity: set.gravity.clone(),
            };
            Some(markers::build_pose(
                &candidate,
                object.as_ref(),
                s.with.poses().closing_axis(),
                reply.recommendations.get(i)?,
                s.with.settings(),
            ))
        });
        (reply, markers)
    }
}

/// How often the set thread, waiting for a pose set's mesh, looks whether the set's time ran out
/// or the node is stopping.
const LOAD_POLL: Duration = Duration::from_millis(20);

/// A pose set's object, made on a loader thread when its mesh must be loaded or a large inline
/// mesh indexed, waited for no longer than `max_mesh_load_time` nor than the set's
/// `max_set_time` (whose clock is watching); refused at once when the inline mesh is beyond
/// `max_inline_mesh_triangles` or no loader thread is free. A load not waited for goes on in the
/// background and fills the cache.
fn object_within(s: &Solving, o: &crate::msg::GraspObject) -> Result<Object, Refused> {
    let answerer = s.with.poses();
    if let Some(why) = answerer.inline_too_large(o) {
        return Err(Refused::from(why));
    }
    let scale = [o.scale.x, o.scale.y, o.scale.z];
    let loads = !o.mesh.is_empty() && !s.meshes.holds(&o.mesh, scale);
    let indexes = o.inline_mesh.triangles.len() >= INLINE_OFF_THREAD_TRIANGLES;
    if !loads && !indexes {
        return answerer.object(o).map_err(Refused::from);
    }
    let (made, wait) = mpsc::sync_channel(1);
    let (on_thread, object) = (answerer.clone(), o.clone());
    let started = s.loaders.spawn(move || {
        made.send(on_thread.object(&object).map_err(Refused::from))
            .ok();
    });
    if !started {
        return Err(refusal(format!(
            "object: too many meshes loading ({} loader threads busy); send the set again later",
            s.loaders.max()
        )));
    }
    let deadline = Instant::now() + s.load_time;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match wait.recv_timeout(left.min(LOAD_POLL)) {
            Ok(made) => return made,
            Err(mpsc::RecvTimeoutError::Disconnected) => return Err(refusal(LOAD_PANICKED)),
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
        match s.interrupt.halt() {
            Some(Halt::OutOfTime) => {
                return Err(refusal(format!(
                    "object: its mesh was not loaded within max_set_time ({} s); the load goes \
                     on in the background: send the set again later",
                    s.budget
                )))
            }
            Some(Halt::Stopping) => {
                return Err(refusal(
                    "object: its mesh was not loaded: the node is stopping",
                ))
            }
            None => {}
        }
        if Instant::now() >= deadline {
            return Err(refusal(too_slow(s.load_time)));
        }
    }
}

/// A pose set's object refused with status 2, saying `why`.
fn refusal(why: impl Into<String>) -> Refused {
    Refused {
        status: GripRecommendation::STATUS_INVALID_INPUT,
        message: why.into(),
    }
}
