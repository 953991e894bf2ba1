//! The two fingers cast onto the object: from a gripper pose and an opening to two contacts
//! with inward normals.
//!
//! # The fingers
//! Let `c` be the tool frame's origin and `b` its closing axis (x, y or z of the tool frame,
//! [`ClosingAxis`]), both in the header frame, and `w` the opening. Finger 1 starts at
//! `c − (w/2)·b` and moves along `+b`; finger 2 starts at `c + (w/2)·b` and moves along `−b`.
//! Each moves at most `w`, to the other finger's start. Its contact is the first surface point it
//! touches; the contact normal is the surface normal there, pointing into the object.
//!
//! - A finger that meets nothing on its way: [`GeometryError::ClosesOnNothing`] (both fingers
//!   travel the same segment, so finger 1 is the one named).
//! - A finger that starts inside the object by more than the tolerance (the opening is narrower
//!   than the object along the closing line): [`GeometryError::StartsInside`]. A finger that
//!   starts on the surface (within the tolerance) touches it at once.
//! - Open meshes have no inside: a finger starting "inside" one is not detected, and its contact
//!   is the first triangle it meets, with the normal turned away from the finger.
//!
//! # Edges and vertices: the pseudo-normal
//! Where the contact lies on an edge or a vertex (within [`FEATURE_TOLERANCE`] times the
//! object's size), the surface normal is not unique. The contact then takes the
//! *pseudo-normal* (Bærentzen and Aanæs): on an edge, the mean of its two faces' unit normals;
//! on a vertex, the mean of its faces' unit normals weighted by the faces' angles at the vertex.
//! It lies inside the cone of the faces' normals, is symmetric, and is the normal itself where
//! the faces are coplanar (it is also what parry uses to tell inside from outside). The [`Contact`]
//! reports [`Feature::Edge`] or [`Feature::Vertex`] when the faces there are not coplanar, so a
//! caller may refuse such a grasp.
//! - Box: an edge averages its two faces' normals, a corner its three.
//! - Cylinder: on a rim, the mean of the cap's normal and the radial normal.
//! - Cone: on the base rim, the mean of the base's normal and the side's normal; at the tip, the
//!   axis `+z` (the angle-weighted mean of the side's normals around the tip).
//! - Closed mesh: the pseudo-normal of the edge or vertex, from the triangles there. Open mesh:
//!   the hit triangle's normal (an open mesh's faces need not be oriented alike, so their mean
//!   means nothing).
//!
//! # Exactness
//! Box and sphere: parry's closed-form ray casts. Mesh: parry's ray-triangle test (exact for each
//! triangle) over a compact copy of parry's BVH (`crate::bvh`, whose boxes contain parry's). Cylinder and cone: closed forms in this file, because parry casts a ray on
//! them by GJK iterations, whose normals were measured up to 1.9e-4 rad (cylinder) and 1.2e-3
//! rad (cone) from the exact ones.

use std::fmt;
use std::str::FromStr;

use nalgebra::{Isometry3, Point3, UnitVector3, Vector3};
use parry3d_f64::math::Vector;
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::{Ball, Cuboid};

use crate::error::{Finger, GeometryError};
use crate::mesh::Mesh;
use crate::shape::{check_pose, Primitive, Shape};

/// A contact lies on an edge or a vertex when it is within this fraction of the object's size
/// (the diagonal of its bounding box) of one. The same tolerance separates "starts on the
/// surface" from "starts inside".
pub const FEATURE_TOLERANCE: f64 = 1e-10;

/// The axis of the tool frame along which the fingers close.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum ClosingAxis {
    /// Contact-GraspNet: `R[:, 0]`.
    X,
    /// The default: the Franka hand, GPD's binormal, graspnetAPI's `R[:, 1]`.
    #[default]
    Y,
    /// Some grippers' own frames.
    Z,
}

impl ClosingAxis {
    /// The names `FromStr` accepts.
    pub const NAMES: [&'static str; 3] = ["x", "y", "z"];

    /// The axis as a unit vector of the tool frame.
    pub fn unit(self) -> UnitVector3<f64> {
        match self {
            ClosingAxis::X => Vector3::x_axis(),
            ClosingAxis::Y => Vector3::y_axis(),
            ClosingAxis::Z => Vector3::z_axis(),
        }
    }
}

impl fmt::Display for ClosingAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            ClosingAxis::X => "x",
            ClosingAxis::Y => "y",
            ClosingAxis::Z => "z",
        };
        f.write_str(name)
    }
}

/// A closing axis other than `x`, `y` or `z`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{given:?} is not a closing axis (x, y or z)")]
#[non_exhaustive]
pub struct UnknownClosingAxis {
    /// What was given.
    pub given: String,
}

impl FromStr for ClosingAxis {
    type Err = UnknownClosingAxis;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "x" => Ok(ClosingAxis::X),
            "y" => Ok(ClosingAxis::Y),
            "z" => Ok(ClosingAxis::Z),
            _ => Err(UnknownClosingAxis {
                given: s.to_owned(),
            }),
        }
    }
}

/// The gripper: its tool frame in the header frame, its opening and its closing axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripperPose {
    /// The tool frame in the header frame (`grasp_pose`).
    pub tool_pose: Isometry3<f64>,
    /// The opening before closing, m, > 0.
    pub width: f64,
    /// Which axis of the tool frame the fingers close along.
    pub closing_axis: ClosingAxis,
}

/// The object: its frame in the header frame and its shape in that frame.
#[derive(Debug, Clone)]
pub struct Object {
    /// The object frame in the header frame.
    pub pose: Isometry3<f64>,
    /// The shape, in the object frame, metres.
    pub shape: Shape,
}

/// Where on the surface a contact lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Inside a face, or where the faces meeting are coplanar: the normal is unique.
    Face,
    /// On an edge between faces that are not coplanar: the normal is the pseudo-normal.
    Edge,
    /// On a vertex (a box's corner, a cone's tip): the normal is the pseudo-normal.
    Vertex,
}

/// One finger's contact, in the header frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The contact point, m.
    pub point: Point3<f64>,
    /// The surface normal there, pointing into the object.
    pub normal: UnitVector3<f64>,
    /// Face, edge or vertex.
    pub feature: Feature,
    /// How far the finger moved from its start, m.
    pub travel: f64,
}

/// The two contacts `[finger 1, finger 2]` of a gripper pose on an object, in the header frame.
///
/// # Example
/// ```
/// use grasp_orient_geometry::{cast_fingers, ClosingAxis, GripperPose, Object, Primitive};
/// use nalgebra::{Isometry3, Vector3};
///
/// // A 4 cm cube, the gripper 10 cm open around its centre, closing along y.
/// let object = Object {
///     pose: Isometry3::identity(),
///     shape: Primitive::Box { x: 0.04, y: 0.04, z: 0.04 }.into(),
/// };
/// let gripper = GripperPose {
///     tool_pose: Isometry3::translation(0.0, 0.0, 0.01),
///     width: 0.1,
///     closing_axis: ClosingAxis::Y,
/// };
/// let [c1, c2] = cast_fingers(&gripper, &object)?;
/// assert!((c1.point.y + 0.02).abs() < 1e-15 && (c2.point.y - 0.02).abs() < 1e-15);
/// assert!((c1.normal.into_inner() - Vector3::y()).norm() < 1e-15); // into the object
/// assert!((c1.travel - 0.03).abs() < 1e-15);
/// # Ok::<(), grasp_orient_geometry::GeometryError>(())
/// ```
pub fn cast_fingers(gripper: &GripperPose, object: &Object) -> Result<[Contact; 2], GeometryError> {
    check_pose(&gripper.tool_pose, "grasp_pose")?;
    check_pose(&object.pose, "object pose")?;
    let width = gripper.width;
    if !(width.is_finite() && width > 0.0) {
        return Err(GeometryError::BadNumber {
            field: "width",
            positive: true,
        });
    }
    if let Shape::Primitive(primitive) = &object.shape {
        primitive.check()?;
    }
    let b = gripper.tool_pose.rotation * gripper.closing_axis.unit().into_inner();
    let centre = gripper.tool_pose.translation.vector;
    let tolerance = FEATURE_TOLERANCE * object.shape.size();
    let cast = |finger: Finger| -> Result<Contact, GeometryError> {
        let sign = if finger == Finger::One { -1.0 } else { 1.0 };
        let start = Point3::from(centre + b * (sign * width / 2.0));
        let direction = -sign * b;
        let origin = object.pose.inverse_transform_point(&start);
        let local_direction = object.pose.inverse_transform_vector(&direction);
        let ray = LocalRay {
            origin: origin.coords,
            direction: local_direction,
            max: width,
            tolerance,
        };
        match cast_local(&object.shape, &ray) {
            LocalCast::Inside => Err(GeometryError::StartsInside {
                finger,
                resource: object.shape.describe(),
            }),
            LocalCast::Miss => Err(GeometryError::ClosesOnNothing { finger }),
            LocalCast::Hit(hit) => Ok(Contact {
                point: start + direction * hit.t,
                normal: UnitVector3::new_normalize(object.pose.rotation * -hit.outward),
                feature: hit.feature,
                travel: hit.t,
            }),
        }
    };
    Ok([cast(Finger::One)?, cast(Finger::Two)?])
}

/// What the 3D solver takes from a pose candidate: the two contacts and the centre of mass, all
/// in the header frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grasp {
    /// `[finger 1, finger 2]`.
    pub contacts: [Contact; 2],
    /// The given centre of mass, or the shape's ([`crate::mass::center_of_mass`]).
    pub center_of_mass: Point3<f64>,
}

/// The contacts ([`cast_fingers`]) and the centre of mass ([`crate::mass::center_of_mass`],
/// `given` in the object frame) of a pose candidate.
///
/// The centre of mass comes first: a mesh that cannot give one without `given` is wrong input
/// (status 2) whatever the fingers meet.
pub fn grasp_from_pose(
    gripper: &GripperPose,
    object: &Object,
    given: Option<Point3<f64>>,
) -> Result<Grasp, GeometryError> {
    let center_of_mass = crate::mass::center_of_mass(&object.pose, &object.shape, given)?;
    let contacts = cast_fingers(gripper, object)?;
    Ok(Grasp {
        contacts,
        center_of_mass,
    })
}

/// A finger's ray in the object frame: unit direction, at most `max` long.
struct LocalRay {
    origin: Vector3<f64>,
    direction: Vector3<f64>,
    max: f64,
    tolerance: f64,
}

impl LocalRay {
    fn at(&self, t: f64) -> Vector3<f64> {
        self.origin + self.direction * t
    }

    fn parry(&self) -> Ray {
        Ray::new(glam(&self.origin), glam(&self.direction))
    }
}

/// The first surface point, with its outward (pseudo-)normal in the object frame.
struct LocalHit {
    t: f64,
    outward: Vector3<f64>,
    feature: Feature,
}

enum LocalCast {
    Inside,
    Miss,
    Hit(LocalHit),
}

fn cast_local(shape: &Shape, ray: &LocalRay) -> LocalCast {
    match shape {
        Shape::Primitive(Primitive::Box { x, y, z }) => {
            cast_box(Vector3::new(x / 2.0, y / 2.0, z / 2.0), ray)
        }
        Shape::Primitive(Primitive::Sphere { radius }) => cast_sphere(*radius, ray),
        Shape::Primitive(Primitive::Cylinder { height, radius }) => {
            cast_cylinder(height / 2.0, *radius, ray)
        }
        Shape::Primitive(Primitive::Cone { height, radius }) => {
            cast_cone(height / 2.0, *radius, ray)
        }
        Shape::Mesh(mesh) => cast_mesh(mesh, ray),
    }
}

fn glam(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

fn nalgebra(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn feature_of(faces: usize) -> Feature {
    match faces {
        0 | 1 => Feature::Face,
        2 => Feature::Edge,
        _ => Feature::Vertex,
    }
}

/// parry's slab test for the distance; the faces within the tolerance for the normal.
fn cast_box(half: Vector3<f64>, ray: &LocalRay) -> LocalCast {
    let excess = (ray.origin.abs() - half).max();
    if excess < -ray.tolerance {
        return LocalCast::Inside;
    }
    let Some(t) = Cuboid::new(glam(&half)).cast_local_ray(&ray.parry(), ray.max, true) else {
        return LocalCast::Miss;
    };
    let q = ray.at(t);
    let mut outward = Vector3::zeros();
    let mut faces = 0;
    for i in 0..3 {
        if q[i].abs() >= half[i] - ray.tolerance {
            outward[i] = q[i].signum();
            faces += 1;
        }
    }
    if faces == 0 {
        // Not reached for a point parry puts on the surface; the nearest face otherwise.
        let i = (q.abs() - half).imax();
        outward[i] = q[i].signum();
    }
    LocalCast::Hit(LocalHit {
        t,
        outward: outward.normalize(),
        feature: feature_of(faces),
    })
}

fn cast_sphere(radius: f64, ray: &LocalRay) -> LocalCast {
    if ray.origin.norm() < radius - ray.tolerance {
        return LocalCast::Inside;
    }
    match Ball::new(radius).cast_local_ray(&ray.parry(), ray.max, true) {
        Some(t) => LocalCast::Hit(LocalHit {
            t,
            outward: ray.at(t).normalize(),
            feature: Feature::Face,
        }),
        None => LocalCast::Miss,
    }
}

/// The real roots of `a t² + 2 b t + c = 0` (a linear equation when `a = 0`), computed without
/// cancellation.
fn roots(a: f64, b: f64, c: f64) -> [Option<f64>; 2] {
    if a == 0.0 {
        return if b == 0.0 {
            [None, None]
        } else {
            [Some(-c / (2.0 * b)), None]
        };
    }
    let discriminant = b * b - a * c;
    if discriminant < 0.0 {
        return [None, None];
    }
    let q = -(b + discriminant.sqrt().copysign(b));
    if q == 0.0 {
        return [Some(0.0), None];
    }
    [Some(q / a), Some(c / q)]
}

/// The earliest candidate `t` in `[−tolerance, max]`, clamped to `≥ 0`.
fn earliest<T>(candidates: impl IntoIterator<Item = (f64, T)>, ray: &LocalRay) -> Option<(f64, T)> {
    candidates
        .into_iter()
        .filter(|(t, _)| *t >= -ray.tolerance && *t <= ray.max)
        .min_by(|p, q| p.0.total_cmp(&q.0))
        .map(|(t, s)| (t.max(0.0), s))
}

#[derive(Clone, Copy)]
enum Part {
    Side,
    Cap,
}

/// Axis z, caps at `z = ±half_height`.
///
/// # Formula
/// Side: `(o_x + t d_x)² + (o_y + t d_y)² = r²`, i.e. `a t² + 2 b t + c = 0` with
/// `a = d_x² + d_y²`, `b = o_x d_x + o_y d_y`, `c = o_x² + o_y² − r²`, kept where `|z| ≤ h/2`.
/// Cap facing the finger: `z = −sign(d_z)·h/2`, kept where `x² + y² ≤ r²`. Outward normals
/// `(x, y, 0)/r` and `(0, 0, sign z)`.
fn cast_cylinder(half_height: f64, radius: f64, ray: &LocalRay) -> LocalCast {
    let (o, d, tol) = (ray.origin, ray.direction, ray.tolerance);
    if o.xy().norm() < radius - tol && o.z.abs() < half_height - tol {
        return LocalCast::Inside;
    }
    let a = d.x * d.x + d.y * d.y;
    let b = o.x * d.x + o.y * d.y;
    let c = o.x * o.x + o.y * o.y - radius * radius;
    let side = if a > 0.0 {
        roots(a, b, c)
    } else {
        [None, None]
    };
    let side = side
        .into_iter()
        .flatten()
        .filter(|&t| ray.at(t).z.abs() <= half_height + tol)
        .map(|t| (t, Part::Side));
    let cap = (d.z != 0.0)
        .then(|| (-half_height.copysign(d.z) - o.z) / d.z)
        .filter(|&t| ray.at(t).xy().norm() <= radius + tol)
        .map(|t| (t, Part::Cap));
    let Some((t, part)) = earliest(side.chain(cap), ray) else {
        return LocalCast::Miss;
    };
    let q = ray.at(t);
    let radial = Vector3::new(q.x, q.y, 0.0);
    let axial = Vector3::new(0.0, 0.0, q.z.signum());
    let on_rim = match part {
        Part::Side => q.z.abs() >= half_height - tol,
        Part::Cap => radial.norm() >= radius - tol,
    };
    let (outward, feature) = match (part, on_rim) {
        (_, true) => (radial.normalize() + axial, Feature::Edge),
        (Part::Side, false) => (radial, Feature::Face),
        (Part::Cap, false) => (axial, Feature::Face),
    };
    LocalCast::Hit(LocalHit {
        t,
        outward: outward.normalize(),
        feature,
    })
}

/// Axis z, base disc at `z = −h/2` of radius `r`, tip at `z = +h/2`.
///
/// # Formula
/// With `k = r/h` and `u = h/2 − z` (the depth below the tip), the side is `ρ = k u` for
/// `0 ≤ u ≤ h`. Along the ray `u = u₀ − t d_z`, and `ρ² − k² u² = 0` is `a t² + 2 b t + c = 0`
/// with `a = d_x² + d_y² − k² d_z²`, `b = o_x d_x + o_y d_y + k² u₀ d_z`,
/// `c = o_x² + o_y² − k² u₀²`; roots are kept where `0 ≤ u ≤ h`. The base is the plane
/// `z = −h/2` where `ρ ≤ r`, met when `d_z > 0`. Outward normals: side `(x/ρ, y/ρ, k)/√(1 + k²)`,
/// base `(0, 0, −1)`.
fn cast_cone(half_height: f64, radius: f64, ray: &LocalRay) -> LocalCast {
    let (o, d, tol) = (ray.origin, ray.direction, ray.tolerance);
    let height = 2.0 * half_height;
    let k = radius / height;
    let u0 = half_height - o.z;
    let depth_inside = (k * u0 - o.xy().norm()) / (1.0 + k * k).sqrt();
    if depth_inside > tol && o.z > -half_height + tol {
        return LocalCast::Inside;
    }
    let a = d.x * d.x + d.y * d.y - k * k * d.z * d.z;
    let b = o.x * d.x + o.y * d.y + k * k * u0 * d.z;
    let c = o.x * o.x + o.y * o.y - k * k * u0 * u0;
    let side = roots(a, b, c)
        .into_iter()
        .flatten()
        .filter(|&t| {
            let u = u0 - t * d.z;
            u >= -tol && u <= height + tol
        })
        .map(|t| (t, Part::Side));
    let base = (d.z > 0.0)
        .then(|| (-half_height - o.z) / d.z)
        .filter(|&t| ray.at(t).xy().norm() <= radius + tol)
        .map(|t| (t, Part::Cap));
    let Some((t, part)) = earliest(side.chain(base), ray) else {
        return LocalCast::Miss;
    };
    let q = ray.at(t);
    let rho = q.xy().norm();
    let down = Vector3::new(0.0, 0.0, -1.0);
    let side_normal = |q: Vector3<f64>| Vector3::new(q.x / rho, q.y / rho, k).normalize();
    let (outward, feature) = match part {
        Part::Side if half_height - q.z <= tol => (Vector3::z(), Feature::Vertex),
        Part::Side if q.z + half_height <= tol => (side_normal(q) + down, Feature::Edge),
        Part::Side => (side_normal(q), Feature::Face),
        Part::Cap if rho >= radius - tol => (side_normal(q) + down, Feature::Edge),
        Part::Cap => (down, Feature::Face),
    };
    LocalCast::Hit(LocalHit {
        t,
        outward: outward.normalize(),
        feature,
    })
}

/// The ray cast over the mesh's BVH ([`first_triangle`]), from the tolerance behind the start,
/// so that a start on the surface or inside it by less than the tolerance meets it at once (as
/// the primitives' `t ≥ −tolerance`). For a closed mesh that the finger's way does not meet, the
/// ray runs on past `max`: a start inside meets a back face first (an exit). Where that first hit
/// is on an edge or a vertex, or at the start itself, the back face proves nothing, and rays in
/// other directions decide ([`starts_inside`]).
fn cast_mesh(mesh: &Mesh, ray: &LocalRay) -> LocalCast {
    let trimesh = mesh.trimesh();
    let closed = mesh.is_closed();
    let behind = Ray::new(glam(&ray.at(-ray.tolerance)), glam(&ray.direction));
    // The finger's way first: the first hit there is the first hit on the whole ray, found with
    // the boxes beyond the way left out of the search. Only where the way meets nothing does a
    // closed mesh need the ray beyond it.
    let on_the_way = first_triangle(mesh, &behind, ray.max + ray.tolerance);
    let first = match on_the_way {
        None if closed => first_triangle(mesh, &behind, f64::MAX),
        found => found,
    };
    let Some((id, time_of_impact)) = first else {
        return LocalCast::Miss;
    };
    let t = (time_of_impact - ray.tolerance).max(0.0);
    let triangle = trimesh.triangle(id);
    let q = glam(&ray.at(t));
    let corners = [triangle.a, triangle.b, triangle.c];
    let mut face = nalgebra((triangle.b - triangle.a).cross(triangle.c - triangle.a)).normalize();
    let vertex = (0..3).find(|&i| (q - corners[i]).length() <= ray.tolerance);
    let edge = (0..3).find(|&i| {
        let (p, r) = (corners[i], corners[(i + 1) % 3]);
        let along = r - p;
        along.cross(q - p).length() <= ray.tolerance * along.length()
    });
    if closed && face.dot(&ray.direction) > 0.0 {
        let clear_exit = vertex.is_none() && edge.is_none() && t > 0.0;
        if clear_exit || starts_inside(mesh, ray) {
            return LocalCast::Inside;
        }
    }
    if t > ray.max {
        return LocalCast::Miss;
    }
    if !closed && face.dot(&ray.direction) > 0.0 {
        // Open: the face's side that the finger meets is its outside.
        face = -face;
    }
    let feature = match (vertex, edge) {
        (Some(_), _) => Feature::Vertex,
        (None, Some(_)) => Feature::Edge,
        (None, None) => Feature::Face,
    };
    let corners = trimesh.indices()[id as usize];
    let pseudo = match (closed, vertex, edge) {
        (false, _, _) | (true, None, None) => None,
        (true, Some(i), _) => Some(mesh.vertex_pseudo_normal(corners[i])),
        (true, None, Some(i)) => Some(mesh.edge_pseudo_normal(corners[i], corners[(i + 1) % 3])),
    };
    let (outward, feature) = match pseudo.map(nalgebra) {
        // Coplanar faces: the normal is unique after all.
        Some(n) if n.norm() > 0.0 && n.normalize().cross(&face).norm() <= 1e-12 => {
            (face, Feature::Face)
        }
        Some(n) if n.norm() > 0.0 => (n.normalize(), feature),
        _ => (face, feature),
    };
    LocalCast::Hit(LocalHit {
        t,
        outward,
        feature,
    })
}

/// Whether a start is inside a closed mesh, by rays in three fixed directions: the first of them
/// whose first hit lies inside a face (not on an edge or vertex) and beyond the tolerance tells,
/// by that face's side (a back face is an exit). A ray that meets nothing means outside; if no
/// ray is clear, the start is taken as outside.
fn starts_inside(mesh: &Mesh, ray: &LocalRay) -> bool {
    const DIRECTIONS: [[f64; 3]; 3] = [
        [
            0.267_261_241_912_424_4,
            0.534_522_483_824_848_8,
            0.801_783_725_737_273_2,
        ],
        [
            -0.872_871_560_943_969_6,
            0.218_217_890_235_992_4,
            0.436_435_780_471_984_8,
        ],
        [
            0.301_511_344_577_763_6,
            -0.904_534_033_733_290_9,
            0.301_511_344_577_763_6,
        ],
    ];
    let trimesh = mesh.trimesh();
    let origin = glam(&ray.origin);
    for d in DIRECTIONS {
        let d = Vector::from(d);
        let Some((id, time_of_impact)) = first_triangle(mesh, &Ray::new(origin, d), f64::MAX)
        else {
            return false;
        };
        let triangle = trimesh.triangle(id);
        let q = origin + d * time_of_impact;
        let corners = [triangle.a, triangle.b, triangle.c];
        let near_feature = (0..3).any(|i| {
            let (p, r) = (corners[i], corners[(i + 1) % 3]);
            (r - p).cross(q - p).length() <= ray.tolerance * (r - p).length()
        });
        if !near_feature && time_of_impact > ray.tolerance {
            return (triangle.b - triangle.a)
                .cross(triangle.c - triangle.a)
                .dot(d)
                > 0.0;
        }
    }
    false
}

/// The first triangle a ray meets within `max`, and when: the walk of the mesh's compact copy of
/// parry's BVH ([`crate::bvh`]), which finds what parry's own search of it finds (and, the few
/// times that search misses the first hit, the first hit).
fn first_triangle(mesh: &Mesh, ray: &Ray, max: f64) -> Option<(u32, f64)> {
    mesh.compact_bvh().first_hit(mesh.trimesh(), ray, max)
}
