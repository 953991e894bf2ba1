//! The pose candidate messages (`msg/GraspObject.msg`, `msg/PoseCandidate.msg`, …): a gripper
//! pose and an opening on an object given by a mesh or a primitive, and their answers
//! (`docs/poses.md`).
//!
//! `Mesh`, `MeshTriangle` and `SolidPrimitive` are this package's copies of the fields of
//! `shape_msgs/Mesh`, `shape_msgs/MeshTriangle` and `shape_msgs/SolidPrimitive` (Jazzy), so that
//! the package needs no `shape_msgs`; their JSON is the same as shape_msgs'. `SolidPrimitive`
//! leaves out shape_msgs' `polygon` (for `PRISM`, which is refused) and writes `dimensions`
//! unbounded (shape_msgs: `float64[<=3]`).

use super::{
    CompactString, GripRecommendation, Header, Point, Pose, RosFields, RosMessage, RosType, Vector3,
};
use serde::{Deserialize, Serialize};

ros_message! {
    /// `msg/MeshTriangle.msg`: one triangle of a [`Mesh`].
    MeshTriangle = grasp_orient/MeshTriangle [] {
        /// Indices into [`Mesh::vertices`], counter-clockwise seen from outside.
        vertex_indices: [u32; 3],
    }
}

ros_message! {
    /// `msg/Mesh.msg`: a triangle mesh given inline (shape_msgs/Mesh's fields).
    Mesh = grasp_orient/Mesh [] {
        /// The triangles; empty: no inline mesh.
        #[serde(default)]
        triangles: Vec<MeshTriangle>,
        /// The vertices, object frame, the mesh's units.
        #[serde(default)]
        vertices: Vec<Point>,
    }
}

ros_message! {
    /// `msg/SolidPrimitive.msg`: an exact solid (shape_msgs/SolidPrimitive's type and dimensions).
    SolidPrimitive = grasp_orient/SolidPrimitive [
        BOX: u8 = 1,
        SPHERE: u8 = 2,
        CYLINDER: u8 = 3,
        CONE: u8 = 4,
        PRISM: u8 = 5,
    ] {
        /// `BOX` .. `CONE`; 0: no primitive.
        #[serde(default)]
        kind as "type": u8,
        /// m, as many as the type takes.
        #[serde(default)]
        dimensions: Vec<f64>,
    }
}

/// The scale a JSON object without one has: the mesh is in metres.
fn unit_scale() -> Vector3 {
    Vector3 {
        x: 1.0,
        y: 1.0,
        z: 1.0,
    }
}

ros_message! {
    /// `msg/GraspObject.msg`: the object a gripper pose grasps. Exactly one of `mesh`,
    /// `inline_mesh` and `primitive` is given.
    GraspObject = grasp_orient/GraspObject [] {
        /// The object frame in the header frame.
        pose: Pose,
        /// A mesh resource (`package://`, `file://` or a path); empty: not given.
        #[serde(default)]
        mesh: CompactString,
        /// A mesh given inline; no triangles: not given.
        #[serde(default)]
        inline_mesh: Mesh,
        /// An exact solid; type 0: not given.
        #[serde(default)]
        primitive: SolidPrimitive,
        /// Per-axis factor from a mesh's units to metres, > 0 (1 when absent from JSON); 1 for a
        /// primitive.
        #[serde(default = "unit_scale")]
        scale: Vector3,
        /// kg, > 0.
        mass: f64,
        /// Coulomb coefficient at both contacts, > 0.
        friction: f64,
        /// Whether `center_of_mass` is given.
        #[serde(default)]
        has_center_of_mass: bool,
        /// The centre of mass in the object frame, m, when `has_center_of_mass`.
        #[serde(default)]
        center_of_mass: Point,
        /// The frame `pose` is given in; empty: the candidate's header frame. Only the node turns
        /// it, by TF (`docs/node.md#tf`).
        #[serde(default)]
        frame_id: CompactString,
    }
}

ros_message! {
    /// `msg/PoseCandidate.msg`: a gripper pose and opening on an object.
    PoseCandidate = grasp_orient/PoseCandidate [] {
        /// The frame of every pose and vector.
        #[serde(default)]
        header: Header,
        /// Caller's name for this candidate.
        #[serde(default)]
        id: CompactString,
        /// The tool frame in the header frame.
        grasp_pose: Pose,
        /// The opening before closing, m, > 0.
        width: f64,
        /// The object.
        object: GraspObject,
        /// Gravitational acceleration at the current pose, m/s².
        gravity: Vector3,
    }
}

ros_message! {
    /// `msg/GraspPose.msg`: one gripper pose of a [`PoseCandidateSet`].
    GraspPose = grasp_orient/GraspPose [] {
        /// Caller's name for this pose.
        #[serde(default)]
        id: CompactString,
        /// The tool frame in the set's header frame.
        grasp_pose: Pose,
        /// The opening before closing, m, > 0.
        width: f64,
    }
}

ros_message! {
    /// `msg/PoseCandidateSet.msg`: many gripper poses on one object.
    PoseCandidateSet = grasp_orient/PoseCandidateSet [] {
        /// Stamp and frame of the set.
        #[serde(default)]
        header: Header,
        /// Caller's name for this set.
        #[serde(default)]
        id: CompactString,
        /// The object, once.
        object: GraspObject,
        /// The poses, answered in order.
        #[serde(default)]
        poses: Vec<GraspPose>,
        /// Gravitational acceleration at the current pose, m/s².
        gravity: Vector3,
        /// The most grip force the gripper gives, N; 0 means the `max_grip_force` parameter.
        #[serde(default)]
        max_grip_force: f64,
    }
}

ros_message! {
    /// `msg/PoseRecommendation.msg`: the answer to one [`PoseCandidate`].
    PoseRecommendation = grasp_orient/PoseRecommendation [] {
        /// The answer to the spatial grasp the fingers make.
        recommendation: GripRecommendation,
        /// Finger 1's contact, m (NaN when refused).
        contact_1: Point,
        /// Finger 2's contact, m (NaN when refused).
        contact_2: Point,
        /// Unit inward normal at contact 1.
        normal_1: Vector3,
        /// Unit inward normal at contact 2.
        normal_2: Vector3,
        /// The centre of mass, m.
        center_of_mass: Point,
    }
}

ros_message! {
    /// `msg/PoseRecommendationSet.msg`: the answer to one [`PoseCandidateSet`].
    PoseRecommendationSet = grasp_orient/PoseRecommendationSet [
        STATUS_OK: u8 = 0,
        STATUS_TOO_LARGE: u8 = 1,
        STATUS_INVALID_INPUT: u8 = 2,
    ] {
        /// Stamp and frame of the set.
        header: Header,
        /// Id of the set answered.
        set_id: CompactString,
        /// One per pose, in order.
        recommendations: Vec<PoseRecommendation>,
        /// Indices of the poses answered with status 0, least force first.
        ranking: Vec<u32>,
        /// The [`GripRecommendation`] field the ranking sorts by.
        ranked_by: CompactString,
        /// `STATUS_*` of the set as a whole.
        status: u8,
        /// Why, when status is not OK; empty otherwise.
        message: CompactString,
    }
}

/// `srv/RecommendPoses.srv`, request: the pose set to answer.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecommendPosesRequest {
    /// The set.
    pub pose_set: PoseCandidateSet,
}

/// `srv/RecommendPoses.srv`, response: the pose set's answer.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecommendPosesResponse {
    /// The answer, as on `pose_recommendation_sets`.
    pub recommendation_set: PoseRecommendationSet,
}

impl ros2_client::Message for RecommendPosesRequest {}
impl ros2_client::Message for RecommendPosesResponse {}

impl RosFields for RecommendPosesRequest {
    /// `(name, ROS type)` of each field, as in `srv/RecommendPoses.srv` above `---`.
    fn fields() -> Vec<(&'static str, String)> {
        vec![("pose_set", PoseCandidateSet::ros_type())]
    }
}

impl RosFields for RecommendPosesResponse {
    /// `(name, ROS type)` of each field, as in `srv/RecommendPoses.srv` below `---`.
    fn fields() -> Vec<(&'static str, String)> {
        vec![("recommendation_set", PoseRecommendationSet::ros_type())]
    }
}
