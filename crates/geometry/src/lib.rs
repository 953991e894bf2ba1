//! Two-finger grasp contacts from a gripper pose: the fingers cast onto a mesh or an exact
//! `shape_msgs` primitive, the inward normals there, and the object's centre of mass.
//!
//! Grasp planners (GPD, MoveIt, Contact-GraspNet, graspnetAPI) give a gripper pose and an
//! opening; the solver (`grasp_orient_solver`) takes two contacts, their inward normals and the
//! centre of mass. This crate goes from the one to the other.
//!
//! # Conventions
//! - **Frames.** Everything given and returned is in the *header frame* (the candidate's
//!   `header.frame_id`): the tool pose, the object pose, the contacts, the normals and the
//!   centre of mass. A shape is described in the *object frame*; a given centre of mass too.
//! - **Units.** Metres, after scaling: a mesh's vertices are multiplied per axis by its `scale`
//!   (a mesh in millimetres takes `0.001`). Primitives' dimensions are metres.
//! - **Normals** point into the object: at a contact, the inward normal is minus the outward
//!   surface normal. They are unit vectors.
//! - **The fingers** ([`cast`]): finger 1 starts at `centre − (width/2)·b`, finger 2 at
//!   `centre + (width/2)·b`, `b` the tool frame's closing axis ([`ClosingAxis`], default `y`);
//!   each moves towards the other's start, and its contact is the first surface point it
//!   touches.
//! - **Edges and vertices**, where the normal is not unique, take the pseudo-normal: the mean
//!   of the faces' normals (angle-weighted at a vertex), reported as [`Feature::Edge`] or
//!   [`Feature::Vertex`] ([`cast`] has the rule for each shape).
//! - **Centre of mass** ([`mass`]): a given one wins; else a primitive's centroid, or a closed
//!   mesh's centroid at uniform density by the divergence theorem.
//! - **Primitives** ([`shape`]) follow `shape_msgs/SolidPrimitive`: bounding box centred on the
//!   origin, cylinder and cone along z, the cone's tip at `+height/2`.
//! - **Tolerance**: a point within [`FEATURE_TOLERANCE`] × the object's size (its bounding
//!   box's diagonal) of an edge or vertex is on it, and a finger starting less deep than that
//!   inside the object starts on its surface.
//!
//! # Errors
//! One enum, [`GeometryError`]; [`GeometryError::status`] gives the product's status: 1 when a
//! finger closes on nothing, 2 for input that is wrong (an unreadable or unknown mesh, a bad
//! scale or primitive, an opening narrower than the object, an open mesh without a centre of
//! mass).
//!
//! # Layers
//! A module imports only the modules before it in this list, from the bottom up as parry lays
//! out its own (shapes at the bottom, queries and mass properties above):
//! 1. [`error`], and `bvh.rs` (the compact tree a mesh's casts walk);
//! 2. [`mesh`] (welded, T-junctions split, the closedness check [`check_closed`], indexed), then
//!    [`shape`] (the primitives, [`Shape`], the pose check);
//! 3. [`formats`] (bytes to triangles), then [`load`](mod@load) (files to meshes: `load/resource.rs`,
//!    `access.rs`, `file.rs`, `cache.rs`, each over the ones before);
//! 4. [`mass`] (the centre of mass, over the shapes), then [`cast`] (the fingers, which gives
//!    the centre of mass with the contacts in [`grasp_from_pose`]).
//!
//! # Dependencies
//! parry3d-f64 0.31 (double precision, glam-based math types, converted at this crate's edges:
//! the API speaks nalgebra like the solver) casts the rays on boxes, spheres and triangles,
//! indexes a mesh's triangles in a BVH (walked through a compact copy, `bvh.rs`) and sums a
//! mesh's signed volume; mesh-loader parses STL, OBJ and COLLADA.
//! The cylinder's and cone's ray casts are closed forms here (parry's are GJK iterations).
//!
//! # Example
//! ```
//! use grasp_orient_geometry::{cast_fingers, center_of_mass, ClosingAxis, GripperPose, Object, Primitive};
//! use nalgebra::{Isometry3, Vector3};
//!
//! // A cylinder standing 1 m in front of the robot, grasped from above-ish, closing along x.
//! let object = Object {
//!     pose: Isometry3::translation(1.0, 0.0, 0.5),
//!     shape: Primitive::from_shape_msgs(Primitive::CYLINDER, &[0.2, 0.03])?.into(),
//! };
//! let gripper = GripperPose {
//!     tool_pose: Isometry3::translation(1.0, 0.0, 0.55),
//!     width: 0.08,
//!     closing_axis: ClosingAxis::X,
//! };
//! let [c1, c2] = cast_fingers(&gripper, &object)?;
//! assert!((c1.point.x - 0.97).abs() < 1e-12 && (c2.point.x - 1.03).abs() < 1e-12);
//! assert!((c2.normal.into_inner() + Vector3::x()).norm() < 1e-12);
//! let com = center_of_mass(&object.pose, &object.shape, None)?;
//! assert!((com.z - 0.5).abs() < 1e-15);
//! # Ok::<(), grasp_orient_geometry::GeometryError>(())
//! ```

mod bvh;
pub mod cast;
pub mod error;
pub mod formats;
pub mod load;
pub mod mass;
pub mod mesh;
pub mod shape;

pub use cast::{
    cast_fingers, grasp_from_pose, ClosingAxis, Contact, Feature, Grasp, GripperPose, Object,
    UnknownClosingAxis, FEATURE_TOLERANCE,
};
pub use error::{Finger, GeometryError, MeshDefect};
pub use formats::{parse_bytes, Triangles};
pub use load::{load, parse, resolve, AmentIndex, MeshCache};
pub use mass::center_of_mass;
pub use mesh::{check_closed, Mesh};
pub use shape::{Primitive, Shape};

/// The README's example runs as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeExample;
