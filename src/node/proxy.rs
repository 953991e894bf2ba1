//! The grasp planner proxy: the node's own `grasping_msgs/action/FindGraspableObjects` server,
//! `~/find_graspable_objects`, offered when `grasp_planner_action` names a planner's server of
//! that type. A goal is forwarded to the planner as it came; when the planner's result is back,
//! each of its objects' grasps is ranked exactly as a `~/rank_grasps` call of that object and
//! those grasps is ([`call`]: the object from its primitives or meshes and their poses in its
//! header frame, its mass and friction from `objects_file` by its name, `grasp_planner_width` as
//! the opening): the call goes to the node's thread ([`Relay`]), which turns it into its pose
//! set and sends it the pose sets' one path, and the answer comes back mapped onto the grasps by
//! the function that maps `~/rank_grasps`' ([`super::grasps::ranked`]). The result is the
//! planner's, each object's grasps replaced by the ranked ones (those that cannot be held
//! dropped); an object the node cannot answer (no entry in `objects_file`, a frame TF cannot
//! join, more than one shape...) keeps its grasps as the planner gave them, unranked, and the
//! reason is logged. Support surfaces are returned as they came.
//!
//! The exchange runs in a task of its own on the node's executor, beside the answering loop, as
//! `~/grip`'s does (the same [`exchange`]); goals are taken one after another, each bounded
//! whole by `grasp_planner_timeout`: no planner found, the goal rejected, no result in time, or
//! the rankings not all back in time aborts the proxy's goal, saying which in the log. The
//! objects are ranked one after another, so that a result of many does not fill the set
//! thread's queue. The
//! planner's feedback is not forwarded, and a cancel of the proxy's goal is not taken.

use super::grasps::{Caller, Reply};
use super::grip::{action_client, exchange, within, Failed};
use super::moveit_in;
use super::params::Shared;
use super::requests::{Endpoints, Loop};
use super::session::{qos, say, Session};
use crate::config::Config;
use crate::msg::grasping::{FindFeedback, FindGoal, FindResult, GraspableObject};
use crate::msg::moveit::{CollisionObject, RankGraspsRequest, RankGraspsResponse};
use futures::channel::{mpsc, oneshot};
use ros2_client::action::{
    ActionClient, ActionServerQosPolicies, AsyncActionServer, GoalEndStatus, GoalStatusEnum,
};
use ros2_client::{ActionTypeName, Name, Node, ServiceMapping};
use std::cell::Cell;
use std::time::{Duration, Instant};

/// The action's name in the node's private namespace.
pub(crate) const ACTION: &str = "find_graspable_objects";

/// How long a goal's result waits for its client to ask for it.
const RESULT_WAIT: Duration = Duration::from_secs(10);

/// One object of a planner's result, as the `~/rank_grasps` call it is ranked as, for the node's
/// thread; its ranking goes to `reply`.
pub(crate) struct Relay {
    key: u64,
    call: RankGraspsRequest,
    reply: Reply,
}

/// The objects the proxy's task hands to the node's thread.
pub(crate) type Relays = mpsc::UnboundedReceiver<Relay>;

/// `~/find_graspable_objects` and the planner's action client.
pub(super) struct Proxy {
    server: AsyncActionServer<FindGoal, FindResult, FindFeedback>,
    planner: ActionClient<FindGoal, FindResult, FindFeedback>,
    /// The planner's action, resolved.
    planner_name: String,
    relays: mpsc::UnboundedSender<Relay>,
    shared: Shared,
    next_key: Cell<u64>,
}

/// The planner's action, resolved (as a topic's name: in the namespace, remapped) and parsed,
/// when `grasp_planner_action` is set; a name that is not a ROS name is refused.
pub(super) fn planner_name(
    config: &Config,
    resolve: impl Fn(&str) -> String,
) -> anyhow::Result<Option<(String, Name)>> {
    let asked = &config.grasp_planner_action;
    if asked.is_empty() {
        return Ok(None);
    }
    let full = resolve(asked);
    let parsed = Name::parse(&full).map_err(|e| {
        anyhow::anyhow!("parameter grasp_planner_action: {asked:?} is not a ROS name: {e:?}")
    })?;
    Ok(Some((full, parsed)))
}

/// The type both actions have.
fn action_type() -> ActionTypeName {
    ActionTypeName::new("grasping_msgs", "FindGraspableObjects")
}

impl Proxy {
    /// Offers `~/find_graspable_objects` and the planner's client when `grasp_planner_action` is
    /// set (none otherwise), and says so; with the stream of objects for the node's thread
    /// (which ends at once when there is no proxy).
    pub(super) fn offer(
        session: &mut Session,
        config: &Config,
        shared: &Shared,
    ) -> anyhow::Result<(Option<Self>, Relays)> {
        let (relays, relayed) = mpsc::unbounded();
        let Some((planner_name, parsed)) = planner_name(config, |n| session.topic_name(n))? else {
            return Ok((None, relayed));
        };
        let node = session.node_mut();
        let planner = action_client(node, &parsed, ("grasping_msgs", "FindGraspableObjects"))?;
        let fqn = node.fully_qualified_name();
        let own =
            Name::new(&fqn, ACTION).map_err(|e| anyhow::anyhow!("action {fqn}/{ACTION}: {e:?}"))?;
        let q = qos(10);
        let policies = ActionServerQosPolicies {
            goal_service: q.clone(),
            result_service: q.clone(),
            cancel_service: q.clone(),
            feedback_publisher: q.clone(),
            // As rclpy's and rclcpp's servers offer it: a client that comes late reads it.
            status_publisher: q.durability(ros2_client::qos::Durability::TransientLocal),
        };
        let server = node
            .create_action_server::<FindGoal, FindResult, FindFeedback>(
                ServiceMapping::Enhanced,
                &own,
                &action_type(),
                policies,
            )
            .map_err(|e| anyhow::anyhow!("cannot offer the action {fqn}/{ACTION}: {e:?}"))?;
        say(
            node,
            log::Level::Info,
            &format!(
                "{fqn}/{ACTION} forwards goals to grasping_msgs/action/FindGraspableObjects \
                 {planner_name} and ranks each object's grasps as ~/rank_grasps does"
            ),
        );
        let proxy = Self {
            server: AsyncActionServer::new(server),
            planner,
            planner_name,
            relays,
            shared: shared.clone(),
            next_key: Cell::new(0),
        };
        Ok((Some(proxy), relayed))
    }

    /// Takes goals, one after another, until dropped.
    pub(super) async fn serve(&self, node: &Node) {
        loop {
            let handle = match self.server.receive_new_goal().await {
                Ok(handle) => handle,
                Err(e) => {
                    warn(node, &format!("a goal that did not decode: {e:?}"));
                    continue;
                }
            };
            let Some(goal) = self.server.get_new_goal(handle) else {
                continue;
            };
            let accepted = match self.server.accept_goal(handle).await {
                Ok(accepted) => accepted,
                Err(e) => {
                    warn(node, &format!("a goal could not be accepted: {e:?}"));
                    continue;
                }
            };
            let executing = match self.server.start_executing_goal(accepted).await {
                Ok(executing) => executing,
                Err(e) => {
                    warn(node, &format!("a goal could not be started: {e:?}"));
                    continue;
                }
            };
            let timeout = self.shared.lock().config.grasp_planner_timeout;
            let (status, result) = match self.goal(node, goal, timeout).await {
                Ok(result) => (GoalEndStatus::Succeeded, result),
                Err(why) => {
                    say(
                        node,
                        log::Level::Error,
                        &format!("~/{ACTION}: goal aborted: {why}"),
                    );
                    (GoalEndStatus::Aborted, FindResult::default())
                }
            };
            let sent = within(
                Instant::now() + RESULT_WAIT,
                self.server.send_result_response(executing, status, result),
            )
            .await;
            match sent {
                Some(Ok(())) => {}
                Some(Err(e)) => warn(node, &format!("the result was not sent: {e:?}")),
                None => warn(
                    node,
                    &format!(
                        "the result was not sent: its client did not ask for it within {} s",
                        RESULT_WAIT.as_secs()
                    ),
                ),
            }
        }
    }

    /// One goal: the planner's result, each object's grasps ranked; why not.
    async fn goal(&self, node: &Node, goal: FindGoal, timeout: f64) -> Result<FindResult, String> {
        let deadline = Instant::now() + seconds(timeout);
        let name = &self.planner_name;
        let param = ("grasp_planner_timeout", timeout);
        let (status, mut result) = match exchange(node, &self.planner, goal, deadline, param).await
        {
            Ok(done) => done,
            Err(Failed::NotSent(why)) => return Err(why),
            Err(Failed::NoResult(why)) => {
                return Err(format!("the goal went to the planner at {name}, but {why}"))
            }
        };
        if status != GoalStatusEnum::Succeeded {
            return Err(format!(
                "the planner's goal at {name} ended {status:?}, not Succeeded"
            ));
        }
        let width = self.shared.lock().config.grasp_planner_width;
        // One object at a time: each waits for the set thread as a call would, and a result of
        // many objects does not fill the set thread's queue (whose overflow is answered busy).
        let (mut asked, mut ranked) = (0, 0);
        for object in result.objects.iter_mut().filter(|o| !o.grasps.is_empty()) {
            asked += 1;
            let key = self.next_key.get();
            self.next_key.set(key.wrapping_add(1));
            let (reply, ranking) = oneshot::channel();
            let relay = Relay {
                key,
                call: call(object, width),
                reply,
            };
            if self.relays.unbounded_send(relay).is_err() {
                return Err("the node is stopping".into());
            }
            let name = crate::msg::clip(&object.object.name);
            match within(deadline, ranking).await {
                None => {
                    return Err(format!(
                        "the ranking of object {name:?} was not back within \
                         grasp_planner_timeout ({timeout} s)"
                    ))
                }
                Some(Err(_)) => return Err("the node is stopping".into()),
                Some(Ok(r)) => match take_ranking(object, r) {
                    Ok(()) => ranked += 1,
                    Err(why) => warn(node, &why),
                },
            }
        }
        say(
            node,
            log::Level::Info,
            &format!(
                "~/{ACTION}: the planner at {name} found {} objects; the grasps of {ranked} of \
                 the {asked} with grasps ranked",
                result.objects.len()
            ),
        );
        Ok(result)
    }
}

/// The `~/rank_grasps` call an object of a planner's result is ranked as: a CollisionObject of
/// its name, header and shapes (their poses in the header frame), its grasps, the opening
/// `width` (m) and the parameter `max_grip_force`. An object with no primitive and no mesh is
/// the one of its name the node learned from MoveIt, as in a call giving only an id.
fn call(object: &GraspableObject, width: f64) -> RankGraspsRequest {
    let o = &object.object;
    RankGraspsRequest {
        object: CollisionObject {
            header: o.header.clone(),
            id: o.name.clone(),
            primitives: o.primitives.clone(),
            primitive_poses: o.primitive_poses.clone(),
            meshes: o.meshes.clone(),
            mesh_poses: o.mesh_poses.clone(),
            ..CollisionObject::default()
        },
        grasps: object.grasps.clone(),
        width,
        max_grip_force: 0.0,
    }
}

/// The object's grasps replaced by its ranking's, when the node answered it (set status 0);
/// otherwise left as they came, and why.
fn take_ranking(object: &mut GraspableObject, ranking: RankGraspsResponse) -> Result<(), String> {
    let set = &ranking.recommendation_set;
    if set.status != 0 {
        return Err(format!(
            "object {:?}: its {} grasps are returned unranked: status {}: {}",
            crate::msg::clip(&object.object.name),
            object.grasps.len(),
            set.status,
            set.message
        ));
    }
    object.grasps = ranking.grasps;
    Ok(())
}

/// Takes one object on the node's thread: a `~/rank_grasps` call whose answer goes back to the
/// proxy's task.
pub(super) async fn take(node: &Node, endpoints: &Endpoints, state: &mut Loop<'_>, relay: Relay) {
    endpoints.sets.grasps.reply_to(relay.key, relay.reply);
    let caller = Caller::Proxy(relay.key);
    moveit_in::take_call(node, endpoints, state, caller, relay.call).await;
}

/// Logs a warning about the proxy.
fn warn(node: &Node, what: &str) {
    say(node, log::Level::Warn, &format!("~/{ACTION}: {what}"));
}

/// `grasp_planner_timeout` (checked in [0.001, 3600] s) as a duration.
fn seconds(s: f64) -> Duration {
    Duration::try_from_secs_f64(s).unwrap_or(Duration::from_secs(30))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::grasping::Object;
    use crate::msg::moveit::{Grasp, ShapePrimitive};
    use crate::msg::{Pose, PoseRecommendationSet};

    fn object() -> GraspableObject {
        let mut o = Object {
            name: "mug".into(),
            primitives: vec![ShapePrimitive {
                kind: ShapePrimitive::CYLINDER,
                dimensions: vec![0.1, 0.04],
                ..ShapePrimitive::default()
            }],
            primitive_poses: vec![Pose::default()],
            ..Object::default()
        };
        o.header.frame_id = "camera".into();
        GraspableObject {
            object: o,
            grasps: vec![
                Grasp {
                    id: "a".into(),
                    ..Grasp::default()
                },
                Grasp {
                    id: "b".into(),
                    ..Grasp::default()
                },
            ],
        }
    }

    /// No proxy by default; the timeout and the width are checked against their domains.
    #[test]
    fn the_proxy_parameters_are_checked() {
        let c = Config::default();
        assert_eq!(c.grasp_planner_action, "");
        assert!(planner_name(&c, str::to_string).expect("none").is_none());
        let mut c = Config::default();
        c.set_from_yaml("grasp_planner_action", "find_objects")
            .expect("a string");
        let (full, _) = planner_name(&c, |n| format!("/arm/{n}"))
            .expect("a name")
            .expect("set");
        assert_eq!(full, "/arm/find_objects");
        c.set_from_yaml("grasp_planner_action", "\"no good\"")
            .expect("a string");
        let e = planner_name(&c, |n| format!("/arm/{n}")).expect_err("refused");
        assert!(e.to_string().contains("is not a ROS name"), "{e}");
        let c = Config::default();
        assert_eq!(
            (c.grasp_planner_timeout, c.grasp_planner_width),
            (30.0, 0.1)
        );
        for (name, value, message) in [
            (
                "grasp_planner_timeout",
                "0",
                "parameter grasp_planner_timeout: must be in [0.001, 3600], got 0",
            ),
            (
                "grasp_planner_width",
                "-0.1",
                "parameter grasp_planner_width: must be in [1e-6, 10], got -0.1",
            ),
        ] {
            let mut c = Config::default();
            c.set_from_yaml(name, value).expect("the type is right");
            let e = c.solver_settings().expect_err(value);
            assert_eq!(e.to_string(), message);
        }
    }

    /// An object is the call of its name, header, shapes and grasps.
    #[test]
    fn an_object_is_a_rank_grasps_call() {
        let o = object();
        let c = call(&o, 0.08);
        assert_eq!(c.object.id, "mug");
        assert_eq!(c.object.header.frame_id, "camera");
        assert_eq!(c.object.primitives, o.object.primitives);
        assert_eq!(c.object.primitive_poses, o.object.primitive_poses);
        assert_eq!(c.object.pose, Pose::default());
        assert_eq!(c.grasps, o.grasps);
        assert_eq!((c.width, c.max_grip_force), (0.08, 0.0));
    }

    /// A ranking with status 0 replaces the grasps; another leaves them and says why.
    #[test]
    fn a_ranking_replaces_the_grasps_only_when_answered() {
        let mut o = object();
        let ranked = RankGraspsResponse {
            grasps: vec![o.grasps[1].clone()],
            indices: vec![1],
            ..RankGraspsResponse::default()
        };
        take_ranking(&mut o, ranked).expect("answered");
        assert_eq!(o.grasps.len(), 1);
        assert_eq!(o.grasps[0].id, "b");
        let mut o = object();
        let refused = RankGraspsResponse {
            recommendation_set: PoseRecommendationSet {
                status: 2,
                message: "invalid input: no mass".into(),
                ..PoseRecommendationSet::default()
            },
            ..RankGraspsResponse::default()
        };
        let why = take_ranking(&mut o, refused).expect_err("unranked");
        assert!(why.contains("\"mug\"") && why.contains("no mass"), "{why}");
        assert_eq!(o.grasps, object().grasps);
    }
}
