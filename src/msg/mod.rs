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

pub(crate) use contract::message_type_name;
pub use contract::{RosFields, RosMessage, RosType};
pub use convert::MessageLimits;
pub(crate) use convert::{clip, invalid, short_id, MAX_TEXT_BYTES};

pub use compact_str::CompactString;

/// The [`RosMessage`] and [`RosType`] impls of a struct declared by [`ros_message!`] or
/// `crate_message!`: its ROS name, and its fields and constants as ROS types.
macro_rules! ros_description {
    (
        $name:ident = $package:ident / $ros_name:ident
        [ $( $cname:ident : $cty:ty = $cval:expr ),* ]
        { $( $field:ident $(as $wire:literal)? : $fty:ty ),* }
    ) => {
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

        ros_description! {
            $name = $package / $ros_name
            [ $( $cname : $cty = $cval ),* ]
            { $( $field $(as $wire)? : $fty ),* }
        }
    };
}

/// [`ros_message!`] for a message the crate keeps to itself (another project's, as MoveIt's):
/// the struct and its fields are `pub(crate)`, off the front door.
macro_rules! crate_message {
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
        pub(crate) struct $name {
            $( $(#[$fmeta])* $(#[serde(rename = $wire)])? pub(crate) $field: $fty, )*
        }

        impl $name {
            $( #[allow(missing_docs, dead_code)] pub(crate) const $cname: $cty = $cval; )*
        }

        ros_description! {
            $name = $package / $ros_name
            [ $( $cname : $cty = $cval ),* ]
            { $( $field $(as $wire)? : $fty ),* }
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

mod standard;
pub use standard::{
    Header, Point, Quaternion, TfMessage, Time, Transform, TransformStamped, Vector3,
};

mod candidates;
pub use candidates::{
    GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet, RecommendRequest,
    RecommendResponse,
};

pub(crate) use poses::limit_inline_mesh_decoding;
mod poses;
pub use poses::{
    GraspObject, GraspPose, Mesh, MeshTriangle, PoseCandidate, PoseCandidateSet,
    PoseRecommendation, PoseRecommendationSet, RecommendPosesRequest, RecommendPosesResponse,
    SolidPrimitive,
};

pub(crate) mod grasping;
pub(crate) mod moveit;

mod visualization;
pub use visualization::{
    ColorRgba, CompressedImage, Duration, Marker, MarkerArray, MeshFile, Pose, PoseStamped,
    UvCoordinate,
};
