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
    CompactString, GripRecommendation, Header, Point, Pose, PoseStamped, RosFields, RosMessage,
    RosType, Vector3,
};
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicUsize, Ordering};

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
        /// The triangles; empty: no inline mesh. Decoding keeps at most the bound the node's
        /// parameter `max_inline_mesh_triangles` sets and one more.
        #[serde(default, deserialize_with = "bounded_triangles")]
        triangles: Vec<MeshTriangle>,
        /// The vertices, object frame, the mesh's units. Decoding keeps at most three times
        /// that bound and one more.
        #[serde(default, deserialize_with = "bounded_vertices")]
        vertices: Vec<Point>,
    }
}

/// The most triangles of an inline mesh decoded and kept (vertices: three times as many), and
/// one more, so that a mesh beyond the bound is still seen to be beyond it; 0 until
/// [`limit_inline_mesh_decoding`] sets one: no bound.
static INLINE_MESH_DECODE_BOUND: AtomicUsize = AtomicUsize::new(0);

/// Bounds what decoding keeps of every later inline mesh in this process to `triangles`
/// triangles (and `3 × triangles` vertices) and one more of each, or to a larger bound set
/// before: the bound only grows. The elements beyond it are still read, to reach the message's
/// later fields, and dropped one by one, so that a message of millions of triangles is refused
/// without being decoded into memory whole (a serde `Deserialize` has no other way to learn a
/// bound than a static).
///
/// A bound for the whole process, and who sets it:
///
/// - **The node** sets it to `max_inline_mesh_triangles` at start, before its readers exist,
///   and to every later value in `Live::push`, before that value's version is stamped with the
///   time it is in force from. A message is answered under the version in force when it was
///   received (`Live::version_at`), and its received time is the one RustDDS stamps on arrival,
///   before the message is taken and decoded (a service call's is when it is taken, on the
///   thread that decoded it with nothing run in between: the node's tasks, its parameter
///   services among them, share one thread). So the value it is answered under was set before
///   it was decoded, and the bound when it was decoded was at least that value: a mesh cut at
///   `b + 1` elements is answered under a value of at most `b`, and refused
///   (`PoseAnswerer::bounding_inline`) with words that name no count, the same whether the mesh
///   was cut or not. That is why the bound never shrinks: lowering the parameter lowers what is
///   answered, not what is decoded (the largest value ever set).
/// - **A recording** holds the candidate as the node decoded it, cut meshes cut; `replay`, which
///   never sets the bound and decodes whole, refuses them under the recorded value with the same
///   words, so the answers agree.
/// - **`solve`, `rank`, `plot`, `replay`, `play` and the Python module** never set it: they
///   decode whole (a local user's own input); the commands refuse by count under the config's
///   bound as the node does (`Config::answering`), the Python module has none.
/// - **Tests** share one process: a test that sets the bound runs in a child process of its own
///   (`tests::decoding_beyond_the_bound_keeps_one_more`), so that it cuts no other test's mesh.
pub(crate) fn limit_inline_mesh_decoding(triangles: i64) {
    let triangles = usize::try_from(triangles).unwrap_or(0);
    INLINE_MESH_DECODE_BOUND.fetch_max(triangles, Ordering::SeqCst);
}

/// How many triangles of an inline mesh decoding keeps ([`limit_inline_mesh_decoding`]).
fn triangles_kept() -> usize {
    match INLINE_MESH_DECODE_BOUND.load(Ordering::SeqCst) {
        0 => usize::MAX,
        bound => bound.saturating_add(1),
    }
}

/// A sequence of which at most `keep` elements are kept; the others are decoded and dropped.
struct BoundedSeq<T> {
    keep: usize,
    of: PhantomData<T>,
}

impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for BoundedSeq<T> {
    type Value = Vec<T>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a sequence")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
        // serde's own cap on a size hint: a hostile length preallocates nothing big.
        let hint = seq.size_hint().unwrap_or(0).min(self.keep).min(1 << 16);
        let mut kept = Vec::with_capacity(hint);
        while let Some(element) = seq.next_element::<T>()? {
            if kept.len() < self.keep {
                kept.push(element);
            }
        }
        Ok(kept)
    }
}

/// An inline mesh's triangles (this package's or shape_msgs'), decoded within the bound.
pub(super) fn bounded_triangles<'de, D: serde::Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Vec<T>, D::Error> {
    let keep = triangles_kept();
    d.deserialize_seq(BoundedSeq {
        keep,
        of: PhantomData,
    })
}

/// An inline mesh's vertices, decoded within three times the bound and one more.
pub(super) fn bounded_vertices<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Vec<Point>, D::Error> {
    // Three per triangle kept, and one more: `3 × bound + 1`.
    let keep = match triangles_kept() {
        usize::MAX => usize::MAX,
        t => (t - 1).saturating_mul(3).saturating_add(1),
    };
    d.deserialize_seq(BoundedSeq {
        keep,
        of: PhantomData,
    })
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
        /// The tool frame after the recommended rotation about the grasp centre, in the header
        /// frame or the node's `gravity_frame` (`docs/poses.md`, "The tool pose"); all NaN where
        /// the answer has no rotation.
        #[serde(default)]
        tool_pose: PoseStamped,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{cdr, Quaternion};

    /// A pose candidate whose inline mesh has `n` distinct triangles and `3 n` distinct vertices,
    /// and fields of its own after the mesh, in the object and in the candidate.
    fn candidate(n: u32) -> PoseCandidate {
        let triangles = (0..n)
            .map(|i| MeshTriangle {
                vertex_indices: [3 * i, 3 * i + 1, 3 * i + 2],
            })
            .collect();
        let vertices = (0..3 * n)
            .map(|i| Point {
                x: f64::from(i),
                y: 0.5 + f64::from(i),
                z: -f64::from(i),
            })
            .collect();
        PoseCandidate {
            id: "cut".into(),
            width: 0.09,
            grasp_pose: Pose {
                orientation: Quaternion {
                    w: 1.0,
                    ..Quaternion::default()
                },
                ..Pose::default()
            },
            object: GraspObject {
                inline_mesh: Mesh {
                    triangles,
                    vertices,
                },
                scale: Vector3 {
                    x: 2.0,
                    y: 3.0,
                    z: 4.0,
                },
                mass: 0.25,
                friction: 0.5,
                has_center_of_mass: true,
                center_of_mass: Point {
                    x: 0.125,
                    y: 0.25,
                    z: 0.375,
                },
                ..GraspObject::default()
            },
            gravity: Vector3 {
                x: 0.0,
                y: 0.0,
                z: -9.81,
            },
            ..PoseCandidate::default()
        }
    }

    /// `c` with its inline mesh cut to `triangles` triangles and `vertices` vertices.
    fn cut(c: &PoseCandidate, triangles: usize, vertices: usize) -> PoseCandidate {
        let mut c = c.clone();
        c.object.inline_mesh.triangles.truncate(triangles);
        c.object.inline_mesh.vertices.truncate(vertices);
        c
    }

    /// `c` through CDR and through JSON: both decoders go through the same bound.
    fn decoded(c: &PoseCandidate) -> [PoseCandidate; 2] {
        let bytes = cdr::encode(c).expect("encodes");
        let text = serde_json::to_string(c).expect("encodes");
        [
            cdr::decode(&bytes).expect("decodes"),
            serde_json::from_str(&text).expect("decodes"),
        ]
    }

    /// What [`decoding_beyond_the_bound_keeps_one_more`] checks, in a process of its own (the
    /// bound is the process's): nothing without `GRASP_ORIENT_DECODE_BOUND_CHILD`.
    #[test]
    #[ignore = "run by decoding_beyond_the_bound_keeps_one_more in a process of its own"]
    fn bounded_decoding_child() {
        if std::env::var_os("GRASP_ORIENT_DECODE_BOUND_CHILD").is_none() {
            return;
        }
        let big = candidate(1000);
        let small = candidate(150);
        // No bound set: decoded whole.
        for d in decoded(&big) {
            assert_eq!(d, big, "decoded whole without a bound");
        }
        limit_inline_mesh_decoding(200);
        // One more than the bound of each, in order; every later field decoded as sent.
        for d in decoded(&big) {
            assert_eq!(d.object.inline_mesh.triangles.len(), 201);
            assert_eq!(d.object.inline_mesh.vertices.len(), 601);
            assert_eq!(
                d,
                cut(&big, 201, 601),
                "the first 201 and 601, then the rest"
            );
        }
        // Within the bound: whole.
        for d in decoded(&small) {
            assert_eq!(d, small, "a mesh within the bound decoded whole");
        }
        // A lower value leaves the bound where it was; a higher one raises it.
        limit_inline_mesh_decoding(100);
        for d in decoded(&big) {
            assert_eq!(d, cut(&big, 201, 601), "the bound never shrinks");
        }
        limit_inline_mesh_decoding(400);
        for d in decoded(&big) {
            assert_eq!(d, cut(&big, 401, 1201), "a higher bound");
        }
        // Many more vertices than triangles: the vertices are cut at three per triangle kept.
        let mut soup = candidate(10);
        soup.object.inline_mesh.vertices = candidate(1000).object.inline_mesh.vertices;
        for d in decoded(&soup) {
            assert_eq!(d, cut(&soup, 10, 1201), "vertices cut on their own");
        }
        println!("BOUNDED-DECODING held");
    }

    /// An inline mesh beyond the bound [`limit_inline_mesh_decoding`] sets is decoded to one
    /// more triangle than the bound (and one more vertex than three per triangle), the message's
    /// later fields as sent; a mesh within it is whole; the bound only grows. Checked in a child
    /// process, since the bound is the process's and would cut other tests' meshes.
    #[test]
    fn decoding_beyond_the_bound_keeps_one_more() {
        let out = std::process::Command::new(std::env::current_exe().expect("this test"))
            .args([
                "--exact",
                "msg::poses::tests::bounded_decoding_child",
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ])
            .env("GRASP_ORIENT_DECODE_BOUND_CHILD", "1")
            .output()
            .expect("the child runs");
        let text = String::from_utf8_lossy(&out.stdout).into_owned()
            + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{text}");
        assert!(
            text.contains("BOUNDED-DECODING held"),
            "the child checked nothing: {text}"
        );
    }
}
