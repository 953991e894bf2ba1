//! The service `~/grip` (`grasp_orient/srv/Grip`): sends the grip force of an answer the node
//! gave to the gripper, as the goal of a control_msgs action, and returns the action's result.
//!
//! The force sent is the answer's grip force (the one `gripper_drive` picks: `internal_force`
//! for coupled fingers, `finger_force` for independent ones) times `grip_safety_factor`, capped
//! by `max_grip_force` when that is set: `min(F · k, F_max)`. The answer itself was solved with
//! the friction divided by `friction_safety_factor`, so both margins hold at once. Only an answer
//! with status 0 is sent; [`recent::Recent`] keeps the last [`recent::KEPT`] answers by id.
//!
//! The exchange (the server found, the goal accepted, its result) runs in a task of its own on
//! the node's executor, beside the answering loop: every step is awaited, none blocks the
//! thread, and the whole call is bounded by `grip_timeout`. ros2-client's clients take the next
//! response off one stream and drop any that is not theirs, so two exchanges on one action would
//! lose each other's responses: calls are answered one after another, in order.

mod recent;
mod wire;

pub(crate) use recent::Recent;

use super::params::Shared;
use super::session::{qos, say, Session};
use crate::config::Config;
use crate::msg::Header;
use futures::{Future, StreamExt};
use ros2_client::action::{ActionClient, ActionClientQosPolicies, GoalStatusEnum};
use ros2_client::{
    ActionTypeName, Message, Name, Node, QosProfile, Server, ServiceMapping, ServiceTypeName,
};
use std::time::{Duration, Instant};
use wire::{
    GripRequest, GripResponse, GripperCommand, GripperCommandFeedback, GripperCommandGoal,
    GripperCommandResult, JointState, ParallelGripperFeedback, ParallelGripperGoal,
    ParallelGripperResult,
};

/// The service's name in the node's private namespace.
pub(crate) const SERVICE: &str = "grip";

/// `~/grip`: its server, the gripper's action client (none when no action is set), the answers
/// it may send and the parameters in force.
pub(super) struct Grip {
    server: Server<GripRequest, GripResponse>,
    gripper: Option<Gripper>,
    recent: Recent,
    shared: Shared,
}

/// The gripper's action, of either type, with its resolved name.
enum Gripper {
    /// `control_msgs/action/GripperCommand`.
    Command(
        String,
        ActionClient<GripperCommandGoal, GripperCommandResult, GripperCommandFeedback>,
    ),
    /// `control_msgs/action/ParallelGripperCommand`.
    Parallel(
        String,
        ActionClient<ParallelGripperGoal, ParallelGripperResult, ParallelGripperFeedback>,
    ),
}

/// The action `~/grip` sends to, by parameter and resolved name (as a topic's: in the namespace,
/// remapped), when one is set; both set, or a name that is not a ROS name, is refused.
pub(super) fn action_name(
    config: &Config,
    resolve: impl Fn(&str) -> String,
) -> anyhow::Result<Option<(&'static str, String, Name)>> {
    let (command, parallel) = (&config.gripper_action, &config.parallel_gripper_action);
    let (param, name) = match (command.is_empty(), parallel.is_empty()) {
        (true, true) => return Ok(None),
        (false, true) => ("gripper_action", command),
        (true, false) => ("parallel_gripper_action", parallel),
        (false, false) => anyhow::bail!(
            "parameters gripper_action ({command}) and parallel_gripper_action ({parallel}) are \
             both set: ~/grip sends to one gripper, set only one of them"
        ),
    };
    let full = resolve(name);
    let parsed = Name::parse(&full)
        .map_err(|e| anyhow::anyhow!("parameter {param}: {name:?} is not a ROS name: {e:?}"))?;
    Ok(Some((param, full, parsed)))
}

impl Grip {
    /// Offers `~/grip` and, when `gripper_action` or `parallel_gripper_action` is set, the client
    /// of that action ([`action_name`]), and says so.
    pub(super) fn offer(
        session: &mut Session,
        config: &Config,
        shared: &Shared,
        recent: &Recent,
    ) -> anyhow::Result<Self> {
        let named = action_name(config, |name| session.topic_name(name))?;
        let (command, parallel) = match named {
            Some(("gripper_action", full, name)) => (Some((full, name)), None),
            Some((_, full, name)) => (None, Some((full, name))),
            None => (None, None),
        };
        let node = session.node_mut();
        let gripper = if let Some((full, name)) = command {
            let client = action_client(node, &name, ("control_msgs", "GripperCommand"))?;
            Some(Gripper::Command(full, client))
        } else if let Some((full, name)) = parallel {
            let client = action_client(node, &name, ("control_msgs", "ParallelGripperCommand"))?;
            Some(Gripper::Parallel(full, client))
        } else {
            None
        };
        let fqn = node.fully_qualified_name();
        let full = Name::new(&fqn, SERVICE)
            .map_err(|e| anyhow::anyhow!("service {fqn}/{SERVICE}: {e:?}"))?;
        let service_qos = qos(10);
        let server = node
            .create_server(
                ServiceMapping::Enhanced,
                &full,
                &ServiceTypeName::new("grasp_orient", "Grip"),
                service_qos.clone(),
                service_qos,
            )
            .map_err(|e| anyhow::anyhow!("cannot offer the service {fqn}/{SERVICE}: {e:?}"))?;
        let grip = Self {
            server,
            gripper,
            recent: recent.clone(),
            shared: shared.clone(),
        };
        grip.announce(session.node());
        Ok(grip)
    }

    /// Says where the goals go.
    fn announce(&self, node: &Node) {
        let service = format!("{}/{SERVICE}", node.fully_qualified_name());
        let line = match &self.gripper {
            Some(Gripper::Command(name, _)) => {
                format!("{service} sends grip forces to control_msgs/action/GripperCommand {name}")
            }
            Some(Gripper::Parallel(name, _)) => format!(
                "{service} sends grip forces to control_msgs/action/ParallelGripperCommand {name}"
            ),
            None => format!(
                "{service}: no gripper action set (gripper_action, parallel_gripper_action); \
                 its calls are refused"
            ),
        };
        say(node, log::Level::Info, &line);
    }

    /// Answers calls, one after another, until dropped.
    pub(super) async fn serve(&self, node: &Node) {
        let mut requests = std::pin::pin!(self.server.receive_request_stream());
        while let Some(request) = requests.next().await {
            match request {
                Ok((id, call)) => {
                    let response = self.grip(node, &call.grasp_id).await;
                    let level = if response.sent {
                        log::Level::Info
                    } else {
                        log::Level::Warn
                    };
                    say(
                        node,
                        level,
                        &format!("~/grip {:?}: {}", call.grasp_id, response.message),
                    );
                    if let Err(e) = self.server.async_send_response(id, response).await {
                        say(
                            node,
                            log::Level::Warn,
                            &format!("~/grip: the response was not sent: {e:?}"),
                        );
                    }
                }
                Err(e) => say(
                    node,
                    log::Level::Warn,
                    &format!("~/grip: a request did not decode: {e:?}"),
                ),
            }
        }
    }

    /// One call: the checks, then the exchange.
    async fn grip(&self, node: &Node, grasp_id: &str) -> GripResponse {
        let config = self.shared.lock().config.clone();
        let plan = match plan(&self.recent, &config, grasp_id, self.gripper.is_some()) {
            Ok(plan) => plan,
            Err(refusal) => return refusal,
        };
        let deadline = Instant::now() + seconds(config.grip_timeout);
        match &self.gripper {
            Some(Gripper::Command(name, client)) => {
                let goal = GripperCommandGoal {
                    command: GripperCommand {
                        position: config.grip_position,
                        max_effort: plan.force,
                    },
                };
                let timeout = ("grip_timeout", config.grip_timeout);
                let outcome = exchange(node, client, goal, deadline, timeout).await;
                plan.respond(
                    name,
                    outcome.map(|(status, r)| ActionResult {
                        status,
                        position: r.position,
                        effort: r.effort,
                        stalled: r.stalled,
                        reached_goal: r.reached_goal,
                    }),
                )
            }
            Some(Gripper::Parallel(name, client)) => {
                let joints = &config.parallel_gripper_joints;
                if joints.is_empty() {
                    return plan.respond(
                        name,
                        Err("parallel_gripper_joints is empty: set the joints the \
                             ParallelGripperCommand goal names"
                            .to_string()),
                    );
                }
                let goal = ParallelGripperGoal {
                    command: JointState {
                        header: Header::default(),
                        name: joints.clone(),
                        position: vec![config.grip_position; joints.len()],
                        velocity: Vec::new(),
                        effort: vec![plan.force; joints.len()],
                    },
                };
                let timeout = ("grip_timeout", config.grip_timeout);
                let outcome = exchange(node, client, goal, deadline, timeout).await;
                plan.respond(
                    name,
                    outcome.map(|(status, r)| ActionResult {
                        status,
                        position: r.state.position.first().copied().unwrap_or(f64::NAN),
                        effort: r.state.effort.first().copied().unwrap_or(f64::NAN),
                        stalled: r.stalled,
                        reached_goal: r.reached_goal,
                    }),
                )
            }
            None => plan.respond("", Err("no gripper action".to_string())),
        }
    }
}

/// An action client on the ROS 2 action QoS: reliable, volatile services and feedback, and the
/// status read volatile (which matches the server's transient-local writer).
pub(super) fn action_client<G, R, F>(
    node: &mut Node,
    name: &Name,
    (package, action_type): (&str, &str),
) -> anyhow::Result<ActionClient<G, R, F>>
where
    G: Message + Clone + 'static,
    R: Message + Clone + 'static,
    F: Message + 'static,
{
    let q: QosProfile = qos(10);
    let policies = ActionClientQosPolicies {
        goal_service: q.clone(),
        result_service: q.clone(),
        cancel_service: q.clone(),
        feedback_subscription: q.clone(),
        status_subscription: q,
    };
    node.create_action_client::<G, R, F>(
        ServiceMapping::Enhanced,
        name,
        &ActionTypeName::new(package, action_type),
        policies,
    )
    .map_err(|e| {
        anyhow::anyhow!("cannot make the action client of {name:?} ({action_type}): {e:?}")
    })
}

/// `grip_timeout` (checked in [0.001, 3600] s) as a duration.
fn seconds(s: f64) -> Duration {
    Duration::try_from_secs_f64(s).unwrap_or(Duration::from_secs(5))
}

/// What a call sends, once its answer is found and may be sent.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Plan {
    /// N, the answer's grip force.
    recommended: f64,
    /// N, the effort sent.
    force: f64,
    /// `grip_safety_factor`.
    factor: f64,
    /// The force was cut to `max_grip_force`.
    capped: bool,
}

/// The force sent for a grip force `recommended` (N): times `factor`, capped by `max` (N; 0: no
/// cap). Returns the force and whether it was capped.
fn force_to_send(recommended: f64, factor: f64, max: f64) -> (f64, bool) {
    let force = recommended * factor;
    if max > 0.0 && force > max {
        (max, true)
    } else {
        (force, false)
    }
}

/// The checks before any goal: an id, an answer kept for it with status 0, a gripper action.
fn plan(
    recent: &Recent,
    config: &Config,
    grasp_id: &str,
    has_gripper: bool,
) -> std::result::Result<Plan, GripResponse> {
    let refuse = |recommended: f64, message: String| GripResponse {
        recommended_force: recommended,
        message,
        ..GripResponse::default()
    };
    if grasp_id.is_empty() {
        return Err(refuse(
            0.0,
            "grasp_id is empty: give the candidate_id of an answer".into(),
        ));
    }
    let Some(kept) = recent.get(grasp_id) else {
        return Err(refuse(
            0.0,
            format!(
                "no answer with candidate_id {grasp_id:?} among the last {} the node gave",
                recent::KEPT
            ),
        ));
    };
    let recommended = kept.grip_force(config.gripper_drive);
    if kept.status != 0 {
        return Err(refuse(
            recommended,
            format!(
                "the answer to {grasp_id:?} has status {} ({}): only an answer with status 0 is \
                 sent to the gripper",
                kept.status, kept.message
            ),
        ));
    }
    if !has_gripper {
        return Err(refuse(
            recommended,
            "no gripper action: set gripper_action or parallel_gripper_action".into(),
        ));
    }
    let factor = config.grip_safety_factor;
    let (force, capped) = force_to_send(recommended, factor, config.max_grip_force);
    Ok(Plan {
        recommended,
        force,
        factor,
        capped,
    })
}

/// An action's result, of either type.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ActionResult {
    status: GoalStatusEnum,
    position: f64,
    effort: f64,
    stalled: bool,
    reached_goal: bool,
}

/// How an exchange failed.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Failed {
    /// Not sent: the message says why.
    NotSent(String),
    /// Accepted, but no result: the message says why.
    NoResult(String),
}

impl Plan {
    /// The response to a call whose goal went to `action` with `outcome`.
    fn respond(
        &self,
        action: &str,
        outcome: std::result::Result<ActionResult, impl Into<Failed>>,
    ) -> GripResponse {
        let drive = format!(
            "max_effort {:.6} N ({:.6} N x grip_safety_factor {}{})",
            self.force,
            self.recommended,
            self.factor,
            if self.capped {
                ", capped by max_grip_force"
            } else {
                ""
            }
        );
        let base = GripResponse {
            recommended_force: self.recommended,
            action: action.to_string(),
            ..GripResponse::default()
        };
        match outcome.map_err(Into::into) {
            Ok(r) => GripResponse {
                sent: true,
                force: self.force,
                goal_status: r.status as i8,
                position: r.position,
                effort: r.effort,
                stalled: r.stalled,
                reached_goal: r.reached_goal,
                message: format!("sent {drive} to {action}; the goal ended {:?}", r.status),
                ..base
            },
            Err(Failed::NotSent(why)) => GripResponse {
                message: why,
                ..base
            },
            Err(Failed::NoResult(why)) => GripResponse {
                sent: true,
                force: self.force,
                message: format!("sent {drive} to {action}, but {why}"),
                ..base
            },
        }
    }
}

impl From<String> for Failed {
    fn from(why: String) -> Self {
        Failed::NotSent(why)
    }
}

/// `fut`, or `None` once `deadline` has passed.
pub(super) async fn within<T>(deadline: Instant, fut: impl Future<Output = T>) -> Option<T> {
    smol::future::or(async { Some(fut.await) }, async {
        smol::Timer::at(deadline).await;
        None
    })
    .await
}

/// One goal and its result, all before `deadline` (`timeout`: the parameter and its value in s,
/// for the messages): the server's goal and result services matched, the goal accepted, the
/// result back. A goal accepted but without a result by then is canceled.
pub(super) async fn exchange<G, R, F>(
    node: &Node,
    client: &ActionClient<G, R, F>,
    goal: G,
    deadline: Instant,
    (param, timeout): (&str, f64),
) -> std::result::Result<(GoalStatusEnum, R), Failed>
where
    G: Message + Clone + 'static,
    R: Message + Clone + 'static,
    F: Message + 'static,
{
    let name = client.name().to_string();
    let found = futures::future::join(
        client.goal_client().wait_for_service(node),
        client.result_client().wait_for_service(node),
    );
    if within(deadline, found).await.is_none() {
        return Err(Failed::NotSent(format!(
            "no action server at {name} (none found within {param}, {timeout} s)"
        )));
    }
    let (goal_id, response) = match within(deadline, client.async_send_goal(goal)).await {
        None => {
            return Err(Failed::NotSent(format!(
                "the action server at {name} did not answer the goal within {param} \
                 ({timeout} s)"
            )))
        }
        Some(Err(e)) => {
            return Err(Failed::NotSent(format!("the goal to {name} failed: {e:?}")));
        }
        Some(Ok(sent)) => sent,
    };
    if !response.accepted {
        return Err(Failed::NotSent(format!(
            "the action server at {name} rejected the goal"
        )));
    }
    match within(deadline, client.async_request_result(goal_id)).await {
        Some(Ok(result)) => Ok(result),
        Some(Err(e)) => Err(Failed::NoResult(format!("its result did not come: {e:?}"))),
        None => {
            let canceled = match client.cancel_goal(goal_id) {
                Ok(_) => "the goal was canceled".to_string(),
                Err(e) => format!("its cancel failed: {e:?}"),
            };
            Err(Failed::NoResult(format!(
                "no result came within {param} ({timeout} s); {canceled}"
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::GripRecommendation;
    use crate::msg::RosType as _;

    #[test]
    fn the_force_sent_is_the_grip_force_times_the_factor_capped() {
        assert_eq!(force_to_send(10.0, 1.5, 0.0), (15.0, false));
        assert_eq!(force_to_send(10.0, 1.5, 20.0), (15.0, false));
        assert_eq!(force_to_send(10.0, 1.5, 12.0), (12.0, true));
        assert_eq!(force_to_send(10.0, 1.0, 10.0), (10.0, false));
    }

    fn config() -> Config {
        Config::default()
    }

    #[test]
    fn refusals_say_why() {
        let recent = Recent::default();
        recent.note(&GripRecommendation {
            candidate_id: "ok".into(),
            internal_force: 8.0,
            finger_force: 9.0,
            ..GripRecommendation::default()
        });
        recent.note(&GripRecommendation {
            candidate_id: "bad".into(),
            status: 2,
            message: "mass must be positive".into(),
            ..GripRecommendation::default()
        });
        let c = config();
        let message = |r: std::result::Result<Plan, GripResponse>| r.expect_err("refused").message;
        assert!(message(plan(&recent, &c, "", true)).contains("empty"));
        assert!(message(plan(&recent, &c, "nope", true)).contains("no answer"));
        let bad = message(plan(&recent, &c, "bad", true));
        assert!(
            bad.contains("status 2") && bad.contains("mass must be positive"),
            "{bad}"
        );
        assert!(message(plan(&recent, &c, "ok", false)).contains("gripper_action"));
        let mut c = config();
        c.grip_safety_factor = 2.0;
        c.max_grip_force = 12.0;
        let p = plan(&recent, &c, "ok", true).expect("planned");
        assert_eq!((p.recommended, p.force, p.capped), (8.0, 12.0, true));
        c.gripper_drive = crate::answer::GripperDrive::Independent;
        c.max_grip_force = 0.0;
        let p = plan(&recent, &c, "ok", true).expect("planned");
        assert_eq!((p.recommended, p.force, p.capped), (9.0, 18.0, false));
    }

    /// The defaults (no gripper, factor 1, closed, 5 s) and the domains' ends.
    #[test]
    fn the_grip_parameters_are_checked() {
        let c = Config::default();
        assert_eq!(
            (
                c.gripper_action.as_str(),
                c.parallel_gripper_action.as_str()
            ),
            ("", "")
        );
        assert_eq!(
            (c.grip_safety_factor, c.grip_position, c.grip_timeout),
            (1.0, 0.0, 5.0)
        );
        assert!(c.parallel_gripper_joints.is_empty());
        assert!(action_name(&c, str::to_string).expect("none").is_none());
        for (name, value, message) in [
            (
                "grip_safety_factor",
                "0.5",
                "parameter grip_safety_factor: must be in [1, 1000], got 0.5",
            ),
            (
                "grip_timeout",
                "0",
                "parameter grip_timeout: must be in [0.001, 3600], got 0",
            ),
        ] {
            let mut c = Config::default();
            c.set_from_yaml(name, value).expect("the type is right");
            let e = c.solver_settings().expect_err(value);
            assert_eq!(e.to_string(), message);
        }
        let mut c = Config::default();
        c.set_from_yaml("parallel_gripper_action", "gripper_cmd")
            .expect("a string");
        let (param, full, _) = action_name(&c, |n| format!("/arm/{n}"))
            .expect("a name")
            .expect("set");
        assert_eq!(
            (param, full.as_str()),
            ("parallel_gripper_action", "/arm/gripper_cmd")
        );
    }

    #[test]
    fn field_types_name_their_packages() {
        assert_eq!(GripperCommand::ros_type(), "control_msgs/GripperCommand");
        assert_eq!(JointState::ros_type(), "sensor_msgs/JointState");
    }
}
