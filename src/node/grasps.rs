//! The service `~/rank_grasps` (`grasp_orient/srv/RankGrasps`): MoveIt's grasps of one object,
//! ranked by the grip force each needs. A call is not a kind of its own: it is turned into the
//! pose set it asks about ([`pose_set`]: one pose per grasp, the grasps' frame as the header
//! frame, the object from the call or from the objects the node learned ([`super::scene`]), its
//! mass and friction from `objects_file`), and that set goes the pose sets' one path (the TF
//! gate, the set thread, the recording: it is recorded, and replays, as a pose set). Its answer
//! comes back to [`GraspsService::respond`], which maps it onto the call's grasps ([`ranked`]).
//! The grasp planner proxy ([`super::proxy`]) ranks each object of a planner's result the same
//! way: as a call, its answer sent back to the proxy's task instead of a caller ([`Caller`]).

use crate::answer::GripperDrive;
use crate::kind::{Kind, PoseSets};
use crate::msg::moveit::{Grasp, RankGraspsRequest, RankGraspsResponse};
use crate::msg::{GraspObject, GraspPose, Header, Vector3};
use ros2_client::{Name, Node, RmwRequestId, Server, ServiceMapping, ServiceTypeName};
use std::collections::BTreeMap;
use std::sync::{Mutex, PoisonError};

/// The set a call is answered as (named through its kind).
type PoseSet = <PoseSets as Kind>::Request;
/// That set's answer.
type PoseSetAnswer = <PoseSets as Kind>::Answer;

/// The service's name under the node.
pub(crate) const SERVICE: &str = "rank_grasps";

/// Who a ranking goes to: a caller of `~/rank_grasps`, or the proxy's task (its key for one
/// object of a planner's result).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Caller {
    /// A call of `~/rank_grasps`.
    Service(RmwRequestId),
    /// An object of a goal of `~/find_graspable_objects`.
    Proxy(u64),
}

/// Where the proxy's task waits for one object's ranking.
pub(crate) type Reply = futures::channel::oneshot::Sender<RankGraspsResponse>;

/// A call waiting for its set's answer: its grasps, and the gripper drive in force when it came
/// (which force is the grip force).
#[derive(Debug)]
pub(crate) struct Pending {
    grasps: Vec<Grasp>,
    drive: GripperDrive,
}

/// `~/rank_grasps` and the calls waiting for their answers (as many as the pose sets in the TF
/// gate and on the set thread, which both bound).
pub(crate) struct GraspsService {
    /// The server.
    pub(crate) server: Server<RankGraspsRequest, RankGraspsResponse>,
    /// Locked by the node's thread only; a mutex since the set endpoints are shared with the thread
    /// that reads the sets (`intake.rs`).
    pending: Mutex<BTreeMap<Caller, Pending>>,
    /// Where the proxy's rankings go, by key.
    replies: Mutex<BTreeMap<u64, Reply>>,
}

impl GraspsService {
    /// Offers `~/rank_grasps`.
    pub(crate) fn offer(node: &mut Node, qos: &ros2_client::QosProfile) -> anyhow::Result<Self> {
        let fqn = node.fully_qualified_name();
        let full = Name::new(&fqn, SERVICE)
            .map_err(|e| anyhow::anyhow!("service {fqn}/{SERVICE}: {e:?}"))?;
        let server = node
            .create_server(
                ServiceMapping::Enhanced,
                &full,
                &ServiceTypeName::new("grasp_orient", "RankGrasps"),
                qos.clone(),
                qos.clone(),
            )
            .map_err(|e| anyhow::anyhow!("cannot offer the service {fqn}/{SERVICE}: {e:?}"))?;
        Ok(Self {
            server,
            pending: Mutex::new(BTreeMap::new()),
            replies: Mutex::new(BTreeMap::new()),
        })
    }

    /// Keeps call `id`'s grasps until its answer comes.
    pub(crate) fn hold(&self, id: Caller, grasps: Vec<Grasp>, drive: GripperDrive) {
        self.pending
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(id, Pending { grasps, drive });
    }

    /// Sends the ranking of the proxy's object `key` to `reply` when it comes.
    pub(crate) fn reply_to(&self, key: u64, reply: Reply) {
        self.replies
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(key, reply);
    }

    /// Answers call `id` with its set's `answer`, mapped onto its grasps.
    pub(crate) async fn respond(&self, id: Caller, answer: PoseSetAnswer) -> Result<(), String> {
        let pending = self
            .pending
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(&id);
        let Some(pending) = pending else {
            return Err(format!("a {SERVICE} answer for a call not held"));
        };
        let response = ranked(pending, answer);
        match id {
            Caller::Service(id) => self
                .server
                .async_send_response(id, response)
                .await
                .map_err(|e| format!("cannot send a {SERVICE} response: {e:?}")),
            Caller::Proxy(key) => {
                let reply = self
                    .replies
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .remove(&key);
                let Some(reply) = reply else {
                    return Err(format!("a ranking for the proxy's object {key}, not held"));
                };
                if reply.send(response).is_err() {
                    // A goal that timed out no longer waits: its ranking is dropped.
                    log::debug!("the proxy's object {key}: ranked after its goal ended");
                }
                Ok(())
            }
        }
    }
}

/// The pose set a call asks about, with gravity `gravity` (the parameter: in the grasps' frame,
/// or in `gravity_frame`, from which the TF gate turns it); and why it is refused whole, if it
/// is: its object cannot be had (`object`), or its grasps are not all in one frame.
pub(crate) fn pose_set(
    call: &RankGraspsRequest,
    object: Result<GraspObject, String>,
    gravity: [f64; 3],
) -> (PoseSet, Option<String>) {
    let header: Header = call
        .grasps
        .first()
        .map(|g| g.grasp_pose.header.clone())
        .unwrap_or_default();
    let (object, mut refusal) = match object {
        Ok(o) => (o, None),
        Err(why) => (GraspObject::default(), Some(why)),
    };
    if refusal.is_none() {
        refusal = call
            .grasps
            .iter()
            .enumerate()
            .find(|(_, g)| g.grasp_pose.header.frame_id != header.frame_id)
            .map(|(i, g)| {
                format!(
                    "grasps[{i}] is in frame {:?}, grasps[0] in {:?}: give every grasp_pose in \
                     one frame",
                    crate::msg::clip(&g.grasp_pose.header.frame_id),
                    crate::msg::clip(&header.frame_id)
                )
            });
    }
    let set = PoseSet {
        header,
        id: call.object.id.as_str().into(),
        object,
        poses: call
            .grasps
            .iter()
            .map(|g| GraspPose {
                id: g.id.as_str().into(),
                grasp_pose: g.grasp_pose.pose.clone(),
                width: call.width,
            })
            .collect(),
        gravity: Vector3 {
            x: gravity[0],
            y: gravity[1],
            z: gravity[2],
        },
        max_grip_force: call.max_grip_force,
    };
    (set, refusal)
}

/// The response: the grasps of the set's ranking in its order, each with `max_contact_force`
/// its grip force (N, the force `gripper_drive` picks), `grasp_quality` the least grip force
/// ranked over its own (1 for the first, in (0, 1]; 1 where both are 0) and every point of
/// `grasp_posture` given its grip force as each joint's effort (one point added where it has
/// none); and the whole answer.
pub(crate) fn ranked(pending: Pending, answer: PoseSetAnswer) -> RankGraspsResponse {
    let Pending { grasps, drive } = pending;
    let force = |i: u32| {
        answer
            .recommendations
            .get(i as usize)
            .map_or(f64::NAN, |r| drive.grip_force(&r.recommendation))
    };
    let least = answer.ranking.first().map_or(0.0, |&i| force(i));
    let mut out = RankGraspsResponse::default();
    for &i in &answer.ranking {
        let Some(grasp) = grasps.get(i as usize) else {
            continue;
        };
        let grip = force(i);
        let mut g = grasp.clone();
        g.max_contact_force = grip as f32;
        g.grasp_quality = if grip > 0.0 { least / grip } else { 1.0 };
        let joints = g.grasp_posture.joint_names.len().max(1);
        if g.grasp_posture.points.is_empty() {
            g.grasp_posture.points.push(Default::default());
        }
        for p in &mut g.grasp_posture.points {
            p.effort = vec![grip; joints];
        }
        out.grasps.push(g);
        out.indices.push(i);
    }
    out.recommendation_set = answer;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::moveit::{CollisionObject, JointTrajectory};
    use crate::msg::{GripRecommendation, PoseRecommendation};

    fn grasp(id: &str, frame: &str) -> Grasp {
        let mut g = Grasp {
            id: id.into(),
            ..Grasp::default()
        };
        g.grasp_pose.header.frame_id = frame.into();
        g
    }

    fn call(grasps: Vec<Grasp>) -> RankGraspsRequest {
        RankGraspsRequest {
            object: CollisionObject {
                id: "mug".into(),
                ..CollisionObject::default()
            },
            grasps,
            width: 0.08,
            max_grip_force: 30.0,
        }
    }

    /// One pose per grasp, in the first grasp's frame; grasps in two frames, or an object that
    /// cannot be had, refuse the set whole.
    #[test]
    fn a_call_is_a_pose_set() {
        let c = call(vec![grasp("a", "camera"), grasp("b", "camera")]);
        let (set, refusal) = pose_set(&c, Ok(GraspObject::default()), [0.0, 0.0, -9.8]);
        assert!(refusal.is_none());
        assert_eq!(set.header.frame_id, "camera");
        assert_eq!(set.id, "mug");
        assert_eq!(set.poses.len(), 2);
        assert_eq!((set.poses[1].id.as_str(), set.poses[1].width), ("b", 0.08));
        assert_eq!((set.gravity.z, set.max_grip_force), (-9.8, 30.0));
        let c = call(vec![grasp("a", "camera"), grasp("b", "base")]);
        let (_, refusal) = pose_set(&c, Ok(GraspObject::default()), [0.0; 3]);
        let why = refusal.expect("refused");
        assert!(why.starts_with("grasps[1] is in frame \"base\""), "{why}");
        let (_, refusal) = pose_set(&c, Err("no object".into()), [0.0; 3]);
        assert_eq!(refusal.as_deref(), Some("no object"));
    }

    /// The ranking's grasps in its order, their forces, qualities and efforts filled.
    #[test]
    fn the_answer_is_mapped_onto_the_grasps() {
        let rec = |internal: f64, finger: f64, status: u8| PoseRecommendation {
            recommendation: GripRecommendation {
                internal_force: internal,
                finger_force: finger,
                status,
                ..GripRecommendation::default()
            },
            ..PoseRecommendation::default()
        };
        let answer = PoseSetAnswer {
            recommendations: vec![rec(4.0, 3.0, 0), rec(2.0, 1.0, 0), rec(9.0, 9.0, 3)],
            ranking: vec![1, 0],
            ..PoseSetAnswer::default()
        };
        let mut with_joints = grasp("a", "camera");
        with_joints.grasp_posture = JointTrajectory {
            joint_names: vec!["left".into(), "right".into()],
            points: vec![Default::default(), Default::default()],
            ..JointTrajectory::default()
        };
        let grasps = vec![with_joints, grasp("b", "camera"), grasp("c", "camera")];
        let out = ranked(
            Pending {
                grasps: grasps.clone(),
                drive: GripperDrive::Coupled,
            },
            answer.clone(),
        );
        assert_eq!(out.indices, [1, 0]);
        assert_eq!(
            (out.grasps[0].id.as_str(), out.grasps[1].id.as_str()),
            ("b", "a")
        );
        assert_eq!(out.grasps[0].max_contact_force, 2.0);
        assert_eq!(out.grasps[0].grasp_quality, 1.0);
        assert_eq!(out.grasps[1].grasp_quality, 0.5);
        assert_eq!(out.grasps[0].grasp_posture.points[0].effort, [2.0]);
        let a = &out.grasps[1].grasp_posture;
        assert!(a.points.iter().all(|p| p.effort == [4.0, 4.0]), "{a:?}");
        assert_eq!(out.recommendation_set, answer);
        let out = ranked(
            Pending {
                grasps,
                drive: GripperDrive::Independent,
            },
            answer,
        );
        assert_eq!(out.grasps[1].max_contact_force, 3.0);
        assert!((out.grasps[1].grasp_quality - 1.0 / 3.0).abs() < 1e-15);
    }
}
