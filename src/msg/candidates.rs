//! The grasp candidate messages (`msg/GraspCandidate.msg`, `msg/GripRecommendation.msg`,
//! `msg/GraspCandidateSet.msg`, `msg/GripRecommendationSet.msg`) and the service
//! `srv/Recommend.srv` that answers a set.

use super::{CompactString, Header, Point, Quaternion, RosFields, RosMessage, RosType, Vector3};
use serde::{Deserialize, Serialize};

ros_message! {
    /// `msg/GraspCandidate.msg`: a two-finger grasp to orient. SI units; vectors in the x-y plane
    /// of `header.frame_id` (`model` 0), or in 3D (`model` 1).
    GraspCandidate = grasp_orient/GraspCandidate [
        MODEL_PLANAR: u8 = 0,
        MODEL_SPATIAL: u8 = 1,
    ] {
        /// Stamp and frame of the candidate.
        #[serde(default)]
        header: Header,
        /// Caller's name for this candidate.
        #[serde(default)]
        id: CompactString,
        /// Contact point 1, m.
        contact_1: Point,
        /// Contact point 2, m.
        contact_2: Point,
        /// Inward surface normal at contact 1, any length > 0.
        normal_1: Vector3,
        /// Inward surface normal at contact 2, any length > 0.
        normal_2: Vector3,
        /// Coulomb coefficient at contact 1, > 0.
        friction_1: f64,
        /// Coulomb coefficient at contact 2, > 0.
        friction_2: f64,
        /// Centre of mass, m.
        center_of_mass: Point,
        /// Mass, kg, > 0.
        mass: f64,
        /// Gravitational acceleration at the current pose, m/s².
        gravity: Vector3,
        /// `MODEL_PLANAR` (0, the default: the x-y plane, z ignored) or `MODEL_SPATIAL` (1: every
        /// point and vector in 3D).
        #[serde(default)]
        model: u8,
        /// Half-widths of a box around `center_of_mass` along the frame's axes, m, each >= 0;
        /// zero: known exactly.
        #[serde(default)]
        center_of_mass_tolerance: Vector3,
        /// The mass lies in `mass ± mass_tolerance`, kg, in `[0, mass)`; zero: known exactly.
        #[serde(default)]
        mass_tolerance: f64,
    }
}

ros_message! {
    /// `msg/GripRecommendation.msg`: the answer to one [`GraspCandidate`].
    GripRecommendation = grasp_orient/GripRecommendation [
        STATUS_OK: u8 = 0,
        STATUS_NO_FORCE_CLOSURE: u8 = 1,
        STATUS_INVALID_INPUT: u8 = 2,
        CANDIDATE_C_RECOMMENDED: u8 = 0,
        CANDIDATE_C_NOT_A_MINIMUM: u8 = 1,
        CANDIDATE_C_BEATEN: u8 = 2,
        CANDIDATE_C_OUT_OF_RANGE: u8 = 3,
        STATUS_EXCEEDS_GRIPPER: u8 = 3,
        STATUS_NOT_SOLVED: u8 = 4,
    ] {
        /// Stamp and frame of the candidate.
        header: Header,
        /// Id of the candidate answered.
        candidate_id: CompactString,
        /// `STATUS_*`.
        status: u8,
        /// Why, when status is not OK; empty otherwise.
        message: CompactString,
        /// Rotation of the object about +z of the frame, rad in (-π, π].
        wrist_rotation: f64,
        /// The same rotation.
        rotation: Quaternion,
        /// Unit vector: gravity in the frame after the rotation.
        gravity_direction: Vector3,
        /// Recommended θ in the paper's object frame, rad.
        gravity_angle: f64,
        /// Objective value at the recommendation, N.
        gripping_power: f64,
        /// Squeeze force needed there, N.
        internal_force: f64,
        /// `(N1, F1, N2, F2)` there, N, candidate's labelling.
        contact_forces: [f64; 4],
        /// Objective value at the current pose, N (inf where it cannot be held).
        gripping_power_current: f64,
        /// Squeeze force needed at the current pose, N (inf where it cannot be held).
        internal_force_current: f64,
        /// `"a"` .. `"d"` of Theorem 1.
        grasp_case: CompactString,
        /// Local minima over the graspable range, rad.
        local_minima: Vec<f64>,
        /// Objective at each local minimum, N.
        local_minima_power: Vec<f64>,
        /// `"A"` .. `"E"` where a minimum is a paper candidate, `""` otherwise.
        local_minima_labels: Vec<CompactString>,
        /// Objective minimised.
        objective: CompactString,
        /// The paper candidate the recommendation is, or `""`.
        recommended_label: CompactString,
        /// `CANDIDATE_C_*`.
        candidate_c: u8,
        /// The larger push along the contact line that either finger gives at the recommendation,
        /// N: what each independently driven finger must give.
        #[serde(default)]
        finger_force: f64,
        /// The same at the current pose, N (inf where it cannot be held).
        #[serde(default)]
        finger_force_current: f64,
        /// Unit axis of the rotation `wrist_rotation` and `rotation` describe: +z for a planar
        /// candidate, the smallest rotation's axis for a spatial one.
        #[serde(default)]
        rotation_axis: Vector3,
        /// The nominal object's objective value at the recommended pose, N (equal to
        /// `gripping_power` when the candidate's tolerances are zero).
        #[serde(default)]
        gripping_power_nominal: f64,
    }
}

ros_message! {
    /// `msg/GraspCandidateSet.msg`: many candidates at once.
    GraspCandidateSet = grasp_orient/GraspCandidateSet [] {
        /// Stamp and frame of the set.
        #[serde(default)]
        header: Header,
        /// Caller's name for this set.
        #[serde(default)]
        id: CompactString,
        /// The candidates, answered in order.
        #[serde(default)]
        candidates: Vec<GraspCandidate>,
        /// The most grip force the gripper gives, N; 0 means the node's `max_grip_force`.
        #[serde(default)]
        max_grip_force: f64,
    }
}

ros_message! {
    /// `msg/GripRecommendationSet.msg`: the answer to one [`GraspCandidateSet`].
    GripRecommendationSet = grasp_orient/GripRecommendationSet [
        STATUS_OK: u8 = 0,
        STATUS_TOO_LARGE: u8 = 1,
        STATUS_INVALID_INPUT: u8 = 2,
        STATUS_INCOMPLETE: u8 = 3,
        STATUS_BUSY: u8 = 4,
    ] {
        /// Stamp and frame of the set.
        header: Header,
        /// Id of the set answered.
        set_id: CompactString,
        /// One per candidate, in order.
        recommendations: Vec<GripRecommendation>,
        /// Indices of the candidates with status 0, least force first.
        ranking: Vec<u32>,
        /// The field of [`GripRecommendation`] the ranking sorts by.
        ranked_by: CompactString,
        /// `STATUS_*` of the set as a whole.
        #[serde(default)]
        status: u8,
        /// Why, when status is not OK; empty otherwise.
        #[serde(default)]
        message: CompactString,
    }
}

/// `srv/Recommend.srv`, request: the set to answer.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecommendRequest {
    /// The set.
    pub candidate_set: GraspCandidateSet,
}

/// `srv/Recommend.srv`, response: the set's answer.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecommendResponse {
    /// The answer, as on `grip_recommendation_sets`.
    pub recommendation_set: GripRecommendationSet,
}

impl ros2_client::Message for RecommendRequest {}
impl ros2_client::Message for RecommendResponse {}

impl RosFields for RecommendRequest {
    /// `(name, ROS type)` of each field, as in `srv/Recommend.srv` above `---`.
    fn fields() -> Vec<(&'static str, String)> {
        vec![("candidate_set", GraspCandidateSet::ros_type())]
    }
}

impl RosFields for RecommendResponse {
    /// `(name, ROS type)` of each field, as in `srv/Recommend.srv` below `---`.
    fn fields() -> Vec<(&'static str, String)> {
        vec![("recommendation_set", GripRecommendationSet::ros_type())]
    }
}
