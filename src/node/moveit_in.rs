//! What the node takes from MoveIt on its thread: objects from `/collision_object` and
//! `/planning_scene` into its [`Scene`](super::scene::Scene), and calls of `~/rank_grasps`, each
//! turned into its pose set and admitted through the TF gate like any other set
//! ([`super::grasps`]); a call refused before (its object unknown, without mass, its grasps in
//! two frames) goes the refusals' path, so that it too is answered, counted and recorded.

use super::answer::SetInput;
use super::grasps::{pose_set, Caller};
use super::requests::{Endpoints, Loop};
use super::session::say;
use super::set_worker::Via;
use super::tf_serve;
use super::tf_wait::{Arrival, Request};
use crate::kind::PoseSets;
use crate::msg::moveit::{CollisionObject, PlanningScene, RankGraspsRequest};
use crate::record::now_ns;
use ros2_client::{MessageInfo, Node};

/// Takes one call of `~/rank_grasps` (or one object of the grasp planner proxy's, as a call).
pub(super) async fn take_call(
    node: &Node,
    endpoints: &Endpoints,
    state: &mut Loop<'_>,
    id: Caller,
    call: RankGraspsRequest,
) {
    let received = now_ns();
    let (gravity, _) = state.answerer.tf_settings(received);
    let drive = state.answerer.answering_at(received).rules().drive;
    let object = state.scene.grasp_object(&call.object);
    let (set, refusal) = pose_set(&call, object, gravity.vector);
    endpoints.sets.grasps.hold(id, call.grasps, drive);
    let request = Request::Set(SetInput::new::<PoseSets>(set), Via::Grasps(id));
    match refusal {
        Some(why) => {
            let arrival = Arrival {
                request,
                received,
                sent: received,
            };
            tf_serve::refuse(node, endpoints, state, arrival, &why).await;
        }
        None => tf_serve::admit(node, endpoints, state, request, (received, received)).await,
    }
}

/// Takes one message of `/collision_object`.
pub(super) fn learn_object(
    node: &Node,
    state: &mut Loop<'_>,
    received: Result<(CollisionObject, MessageInfo), impl std::fmt::Debug>,
) {
    match received {
        Ok((object, _)) => {
            if let Err(why) = state.scene.apply(object) {
                say(node, log::Level::Warn, &why);
            }
            log::debug!("MoveIt: {} objects known", state.scene.len());
        }
        Err(e) => log::debug!("a CollisionObject that does not decode: {e:?}"),
    }
}

/// Takes one message of `/planning_scene`.
pub(super) fn learn_scene(
    node: &Node,
    state: &mut Loop<'_>,
    received: Result<(PlanningScene, MessageInfo), impl std::fmt::Debug>,
) {
    match received {
        Ok((scene, _)) => {
            for why in state.scene.apply_scene(scene) {
                say(node, log::Level::Warn, &why);
            }
            log::debug!("MoveIt: {} objects known", state.scene.len());
        }
        Err(e) => log::debug!("a PlanningScene that does not decode: {e:?}"),
    }
}
