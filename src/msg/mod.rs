//! Wire structs mirroring `msg/*.msg` and the standard Jazzy messages field by field (serde,
//! CDR-compatible in declaration order), their conversions to and from solver types, and their
//! `.msg` texts ([`definitions`]).
//!
//! Each struct is declared through `ros_message!`, which also gives its ROS name and derives its
//! ROS field list from the Rust field types, so `tests/it/msg_contract.rs` can check it against the
//! `.msg` file.

pub mod cdr;
mod contract;
pub(crate) mod convert;
pub mod definitions;
pub(crate) mod schema;

pub use contract::{message_type_name, RosMessage, RosType};
pub use convert::MessageLimits;
pub(crate) use convert::{clip, invalid, short_id, MAX_TEXT_BYTES};

pub use compact_str::CompactString;
use serde::{Deserialize, Serialize};

/// Declares a wire struct, its constants, and its [`RosMessage`] description; the ROS name is
/// written `package/Name`. A field whose ROS name is a Rust keyword is written
/// `rust_name as "ros_name": type`.
macro_rules! ros_message {
    (
        $(#[$meta:meta])*
        $name:ident = $package:ident / $ros_name:ident
        [ $( $cname:ident : $cty:ty = $cval:expr ),* $(,)? ]
        {
            $( $(#[$fmeta:meta])* $field:ident $(as $wire:literal)? : $fty:ty ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $( $(#[$fmeta])* $(#[serde(rename = $wire)])? pub $field: $fty, )*
        }

        impl $name {
            $( #[allow(missing_docs)] pub const $cname: $cty = $cval; )*
        }

        impl RosMessage for $name {
            const PACKAGE: &'static str = stringify!($package);
            const NAME: &'static str = stringify!($ros_name);
            const TYPE_NAME: &'static str =
                concat!(stringify!($package), "/msg/", stringify!($ros_name));
            fn fields() -> Vec<(&'static str, String)> {
                vec![ $( (wire_name!($field $(, $wire)?), <$fty as RosType>::ros_type()) ),* ]
            }
            fn constants() -> Vec<(&'static str, String, String)> {
                vec![ $( (stringify!($cname), <$cty as RosType>::ros_type(), ($cval).to_string()) ),* ]
            }
        }

        impl RosType for $name {
            fn ros_type() -> String {
                concat!(stringify!($package), "/", stringify!($ros_name)).to_string()
            }
        }
    };
}

/// The paper's Table 1 as messages (`examples/paper_cases.jsonl`; `tests/it/paper.rs` holds it to
/// the solver's Table 1 fixture), for tests.
#[cfg(test)]
pub(crate) fn paper_cases() -> Vec<GraspCandidate> {
    include_str!("../../examples/paper_cases.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a GraspCandidate"))
        .collect()
}

/// A field's name on the wire: its Rust name, or the name given with `as`.
macro_rules! wire_name {
    ($field:ident) => {
        stringify!($field)
    };
    ($field:ident, $wire:literal) => {
        $wire
    };
}

mod poses;
pub use poses::{
    GraspObject, GraspPose, Mesh, MeshTriangle, PoseCandidate, PoseCandidateSet,
    PoseRecommendation, PoseRecommendationSet, SolidPrimitive,
};

mod tf;
pub use tf::{TfMessage, Transform, TransformStamped};

mod visualization;
pub use visualization::{
    ColorRgba, CompressedImage, Duration, Marker, MarkerArray, MeshFile, Pose, UvCoordinate,
};

ros_message! {
    /// `builtin_interfaces/Time`.
    Time = builtin_interfaces/Time [] {
        /// Seconds since the epoch.
        sec: i32,
        /// Nanoseconds within the second.
        nanosec: u32,
    }
}

ros_message! {
    /// `std_msgs/Header`.
    Header = std_msgs/Header [] {
        /// Time of the data.
        #[serde(default)]
        stamp: Time,
        /// Frame the data is expressed in.
        #[serde(default)]
        frame_id: CompactString,
    }
}

ros_message! {
    /// `geometry_msgs/Point`, m.
    Point = geometry_msgs/Point [] {
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
        /// z, m (ignored by the planar solver).
        #[serde(default)]
        z: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Vector3`.
    Vector3 = geometry_msgs/Vector3 [] {
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z (ignored by the planar solver).
        #[serde(default)]
        z: f64,
    }
}

ros_message! {
    /// `geometry_msgs/Quaternion`.
    Quaternion = geometry_msgs/Quaternion [] {
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
        /// w.
        w: f64,
    }
}

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

impl RecommendRequest {
    /// `(name, ROS type)` of each field, as in `srv/Recommend.srv` above `---`.
    pub fn fields() -> Vec<(&'static str, String)> {
        vec![("candidate_set", GraspCandidateSet::ros_type())]
    }
}

impl RecommendResponse {
    /// `(name, ROS type)` of each field, as in `srv/Recommend.srv` below `---`.
    pub fn fields() -> Vec<(&'static str, String)> {
        vec![("recommendation_set", GripRecommendationSet::ros_type())]
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

impl RecommendPosesRequest {
    /// `(name, ROS type)` of each field, as in `srv/RecommendPoses.srv` above `---`.
    pub fn fields() -> Vec<(&'static str, String)> {
        vec![("pose_set", PoseCandidateSet::ros_type())]
    }
}

impl RecommendPosesResponse {
    /// `(name, ROS type)` of each field, as in `srv/RecommendPoses.srv` below `---`.
    pub fn fields() -> Vec<(&'static str, String)> {
        vec![("recommendation_set", PoseRecommendationSet::ros_type())]
    }
}
