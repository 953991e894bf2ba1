//! `solve_poses`: gripper poses as 4×4 homogeneous transforms (ACRONYM's and graspnetAPI's
//! layout: the tool frame in the object's mesh frame) and openings on one mesh given as arrays,
//! answered by the root crate's answering object as a pose set: the object once, every pose cast
//! onto it and answered as the spatial candidate its fingers make, exactly as a
//! `PoseCandidate` line of `grasp_orient solve` with the same mesh inline is answered.

use crate::chunks::{answer_in_chunks, Threads};
use crate::columns::Columns;
use crate::grasps::compact_str_row;
use grasp_orient::answer::{Answering, PoseAnswerer, Rules};
use grasp_orient::kind::PoseSets;
use grasp_orient::msg::{
    CompactString, GraspObject, GraspPose, GripRecommendation, Mesh, MeshTriangle, Point, Pose,
    PoseCandidateSet, PoseRecommendation, Quaternion, Vector3,
};
use grasp_orient::solver::Settings;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion};
use std::ops::Range;

/// The most a pose's rotation block may differ from a rotation, entry by entry of `RᵀR − I`:
/// float32 data (graspnetAPI's) converted to float64 stays within about 1e-7 of a rotation.
const ROTATION_TOLERANCE: f64 = 1e-5;

/// The fewest poses a thread is given: each chunk is a set of its own, which indexes the mesh
/// again (about as long as casting a few thousand poses on a 100,000-triangle mesh).
const MIN_CHUNK: usize = 8192;

/// The object of every pose: the mesh (object frame, the mesh's units), its scale to metres,
/// mass, friction and the centre of mass when given.
#[derive(Debug, Clone)]
pub(crate) struct Object {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
    pub scale: [f64; 3],
    pub mass: f64,
    pub friction: f64,
    pub center_of_mass: Option<[f64; 3]>,
}

impl Object {
    /// The `GraspObject` of a pose set: the mesh inline, the object frame the poses' frame.
    fn message(&self) -> GraspObject {
        let [sx, sy, sz] = self.scale;
        let com = self.center_of_mass.unwrap_or([0.0; 3]);
        GraspObject {
            pose: Pose::default_identity(),
            inline_mesh: Mesh {
                triangles: self
                    .triangles
                    .iter()
                    .map(|&t| MeshTriangle { vertex_indices: t })
                    .collect(),
                vertices: self
                    .vertices
                    .iter()
                    .map(|&[x, y, z]| Point { x, y, z })
                    .collect(),
            },
            scale: Vector3 {
                x: sx,
                y: sy,
                z: sz,
            },
            mass: self.mass,
            friction: self.friction,
            has_center_of_mass: self.center_of_mass.is_some(),
            center_of_mass: Point {
                x: com[0],
                y: com[1],
                z: com[2],
            },
            ..GraspObject::default()
        }
    }
}

/// `Pose::default()` has a zero quaternion; the identity has `w = 1`.
trait Identity {
    fn default_identity() -> Self;
}

impl Identity for Pose {
    fn default_identity() -> Self {
        let mut p = Pose::default();
        p.orientation.w = 1.0;
        p
    }
}

/// A 4×4 transform (row-major, 16 values) as a `Pose`: the translation column, and the
/// rotation block as a quaternion (Shepperd's method, nalgebra's). Refused, naming the row,
/// when the bottom row is not `[0, 0, 0, 1]` or the block is not a rotation (a reflection, a
/// scale, a shear).
pub(crate) fn pose_of(m: &[f64], row: usize) -> Result<Pose, String> {
    let bottom = [m[12], m[13], m[14], m[15]];
    if bottom != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "poses[{row}]: the bottom row is {bottom:?}, not [0, 0, 0, 1]: not a rigid transform"
        ));
    }
    let r = Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    let off = (r.transpose() * r - Matrix3::identity()).abs().max();
    if off > ROTATION_TOLERANCE || r.determinant() <= 0.0 {
        return Err(format!(
            "poses[{row}]: the upper-left 3x3 block is not a rotation (RᵀR differs from the \
             identity by {off:.3e}, determinant {:.6}); a pose is a rigid transform",
            r.determinant()
        ));
    }
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let pose = Pose {
        position: Point {
            x: m[3],
            y: m[7],
            z: m[11],
        },
        orientation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    };
    Ok(pose)
}

/// The poses and openings of `range`, answered as one pose set on `object`; each refusal of the
/// geometry names its row (the set's `poses[i].` made `row I: `).
fn answer_range(with: &Answering, object: &GraspObject, p: &Poses, range: Range<usize>) -> Columns {
    let Poses {
        poses,
        widths,
        gravity,
        ..
    } = p;
    let set = PoseCandidateSet {
        object: object.clone(),
        poses: range
            .clone()
            .map(|i| GraspPose {
                grasp_pose: poses[i].clone(),
                width: widths[i],
                ..GraspPose::default()
            })
            .collect(),
        gravity: Vector3 {
            x: gravity[0],
            y: gravity[1],
            z: gravity[2],
        },
        ..PoseCandidateSet::default()
    };
    let answered = with.answer::<PoseSets>(&set);
    let mut out = Columns::with_capacity(range.len());
    for (j, (row, p)) in range.zip(&answered.recommendations).enumerate() {
        out.push_pose(p, message(row, j, p), &poses[row].orientation);
    }
    out
}

/// A pose's message as `solve` words it for the same pose alone, with the row named.
fn message(row: usize, within_set: usize, p: &PoseRecommendation) -> CompactString {
    let r = &p.recommendation;
    let local = r.message.replace(&format!("poses[{within_set}]."), "");
    if r.status == GripRecommendation::STATUS_INVALID_INPUT {
        compact_str_row(row, &local)
    } else {
        local.into()
    }
}

/// The inputs of `solve_poses`, checked.
#[derive(Debug)]
pub(crate) struct Poses {
    pub object: Object,
    pub poses: Vec<Pose>,
    pub widths: Vec<f64>,
    pub gravity: [f64; 3],
}

/// Every pose answered, on `threads`: the poses split into one set a thread.
pub(crate) fn solve(
    p: &Poses,
    answerer: &PoseAnswerer,
    settings: &Settings,
    rules: &Rules,
    threads: &Threads,
) -> Columns {
    let n = p.poses.len();
    let object = p.object.message();
    let chunk = n.div_ceil(threads.count()).max(MIN_CHUNK);
    let with = Answering::new(*settings, *rules, answerer.clone());
    answer_in_chunks(n, chunk, threads, |range| {
        answer_range(&with, &object, p, range)
    })
}
