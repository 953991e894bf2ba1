//! A pose candidate answered: the gripper pose and opening on the object → the two contacts, their
//! inward normals and the centre of mass (`grasp_orient_geometry`) → the spatial candidate those
//! make, answered as any [`GraspCandidate`] of model 1 is ([`answer_one`]) → the answer with the
//! derived geometry, all in the candidate's header frame (`docs/poses.md`).
//!
//! # Policy
//! - The object gives exactly one shape: `mesh` (a resource, loaded once per file and scale into
//!   the [`PoseAnswerer`]'s cache), `inline_mesh`, or `primitive`. A primitive's dimensions are
//!   metres: its `scale` must be 1 on every axis.
//! - Both contacts take the object's `friction`; the centre of mass is `center_of_mass` (object
//!   frame) when `has_center_of_mass`, else the shape's centroid. A `center_of_mass` other than
//!   zero with `has_center_of_mass` false is refused: it was meant, and would be ignored.
//! - Quaternions are normalised; one of norm zero or not finite is refused, naming the field.
//! - A finger that closes on nothing: status 1, naming the finger. Everything else the geometry
//!   refuses (an opening narrower than the object, an unreadable or open mesh without a centre
//!   of mass, a bad scale or primitive): status 2, naming the resource or field.
//! - **Edges and vertices** are answered, not refused: the contact takes the pseudo-normal
//!   (`crates/geometry/src/cast.rs`), and `message` says which contact lies on an edge or a
//!   vertex, so a caller who wants a face contact can drop it. A point finger on a convex edge is
//!   a real grasp; the pseudo-normal is the middle of the normals the edge allows.
//! - A set: its object's shape resolved once, each pose answered against it, and the answers
//!   ranked by [`answer_set`] exactly as a [`GraspCandidateSet`]'s (the gripper's limit, the
//!   set's `max_grip_force`, `max_set_size`), a pose refused by the geometry never ranked.

use super::reply::no_closure;
use super::{answer_one, answer_set, Rules};
use crate::msg::{
    invalid, CompactString, GraspCandidate, GraspCandidateSet, GraspObject, GripRecommendation,
    GripRecommendationSet, Header, Point, Pose, PoseCandidate, PoseCandidateSet,
    PoseRecommendation, PoseRecommendationSet, Vector3,
};
use crate::solver::{
    check_friction, check_mass, spatial::check_weight, times_pow2, InvalidInput, Readable,
    Settings, MAX_COORDINATE, MAX_GRAVITY, SQUARE_SAFE,
};
use grasp_orient_geometry::{
    grasp_from_pose, AmentIndex, ClosingAxis, Contact, Feature, GeometryError, Grasp, GripperPose,
    MeshCache, Object, Primitive, Shape,
};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3 as V3};
use std::fmt::{self, Display};
use std::sync::Arc;

/// The most bytes of meshes a [`PoseAnswerer`] keeps loaded (least recently used dropped first).
pub const MESH_CACHE_BYTES: usize = 512 << 20;

/// The largest opening accepted, m: the solver's coordinate limit ([`MAX_COORDINATE`]), since
/// the fingers start `width / 2` from the tool frame's origin. Beyond it the contacts, computed
/// from finger starts `width / 2` away, would have lost every digit of the object's size (an
/// opening of 1e300 m made both contacts the same point).
pub(super) const MAX_WIDTH: f64 = MAX_COORDINATE;
/// The smallest scale factor accepted on a mesh's axis: from nanometres to metres. Below it the
/// mesh shrinks towards a point, and its faces' normals are lost to underflow (a scale of 1e-100
/// made the contact normals NaN).
pub(super) const MIN_SCALE: f64 = 1e-9;
/// The largest scale factor accepted on a mesh's axis. Above it the vertices leave the solver's
/// coordinate limit for any mesh unit in use, and reach infinity from single-precision files.
pub(super) const MAX_SCALE: f64 = 1e9;
/// A finger starting inside a mesh that is, along the closing line, between these many times
/// wider than the opening: the refusal adds a hint that the mesh may be in millimetres without a
/// scale. A mesh in millimetres read as metres is 1000 times too large, so an object from 0.3 to
/// 1000 times the opening in truth (a gripper rarely closes on one more than 300 times its
/// opening) lands here; beyond the upper end it is the opening that is wrong, not the units.
pub(super) const UNITS_HINT_RATIO: std::ops::RangeInclusive<f64> = 300.0..=1e6;

/// What is wrong with one number of a pose candidate (the solver's words for the same faults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum NumberFault {
    /// NaN or infinite.
    NotFinite,
    /// Larger in magnitude than `limit` (with its unit, leading space included).
    Above {
        /// The value.
        value: f64,
        /// The largest accepted magnitude.
        limit: f64,
        /// Its unit, with its leading space.
        unit: &'static str,
    },
    /// Below `minimum`.
    Below {
        /// The value.
        value: f64,
        /// The smallest accepted value.
        minimum: f64,
    },
}

impl Display for NumberFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            NumberFault::NotFinite => f.write_str("is not a finite number"),
            NumberFault::Above { value, limit, unit } => write!(
                f,
                "is out of range: {value:e} exceeds {limit:e}{unit} in magnitude"
            ),
            NumberFault::Below { value, minimum } => write!(
                f,
                "is out of range: {value:e} is below the smallest accepted {minimum:e}"
            ),
        }
    }
}

/// Why a pose candidate cannot be turned into a grasp.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub(crate) enum PoseRefusal {
    /// The geometry's refusal: status 1 for a finger that closes on nothing, 2 otherwise.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// Not exactly one of `mesh`, `inline_mesh` and `primitive` is given.
    #[error("object: give exactly one shape (mesh, inline_mesh or primitive), got {given}")]
    Shapes {
        /// The shapes given, by field name (empty for none).
        given: String,
    },
    /// A primitive with a scale other than 1.
    #[error(
        "object.scale must be 1 on every axis for a primitive (its dimensions are metres), got \
         [{}, {}, {}]", Readable(.scale[0]), Readable(.scale[1]), Readable(.scale[2])
    )]
    PrimitiveScale {
        /// The scale given.
        scale: [f64; 3],
    },
    /// A quaternion that is no rotation.
    #[error("{field} is not a rotation: its norm is {norm}")]
    Orientation {
        /// `grasp_pose.orientation`, `object.pose.orientation`, `poses[i].grasp_pose.orientation`.
        field: String,
        /// Its norm.
        norm: f64,
    },
    /// A number of the pose candidate out of its domain, named by its path in the message
    /// (`grasp_pose.position.x`, `poses[2].width`, `object.scale.y`, …).
    #[error("{field} {fault}")]
    Number {
        /// The field's path.
        field: String,
        /// What is wrong with it.
        fault: NumberFault,
    },
    /// A number the solver refuses, named by the pose candidate's field it comes from
    /// (`object.friction`, which is both contacts' friction; `object.mass`).
    #[error(transparent)]
    Solver(#[from] InvalidInput),
    /// A finger starts inside a mesh that is many times wider than the opening along the closing
    /// line: the geometry's refusal, with a hint about the mesh's units.
    #[error(
        "{source}: the mesh is {} times wider than the opening along the closing line: is it in \
         millimetres? {}",
        Rounded(*.ratio),
        if *.unit_scale { "set object.scale to 0.001" } else { "check object.scale" }
    )]
    StartsInsideUnits {
        /// The geometry's refusal ([`GeometryError::StartsInside`]).
        source: GeometryError,
        /// The mesh's extent along the closing line over the opening.
        ratio: f64,
        /// Whether `object.scale` is 1 on every axis.
        unit_scale: bool,
    },
    /// `center_of_mass` given without `has_center_of_mass`.
    #[error(
        "object.center_of_mass is given but object.has_center_of_mass is false: set it true, or \
         leave center_of_mass at zero for the shape's centroid"
    )]
    CenterOfMassFlag,
}

/// A ratio to about three significant digits, as a plain number (`1000`, `2500`, `15000`).
struct Rounded(f64);

impl Display for Rounded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self.0;
        if !(r.is_finite() && r >= 1.0) {
            return write!(f, "{r:e}");
        }
        let digits = r.log10().floor() as i32;
        let step = 10f64.powi((digits - 2).max(0));
        let rounded = (r / step).round() * step;
        if rounded < 1e16 {
            write!(f, "{rounded:.0}")
        } else {
            write!(f, "{rounded:e}")
        }
    }
}

impl PoseRefusal {
    /// The status of the answer: 1 when a finger closes on nothing, 2 otherwise.
    pub(crate) fn status(&self) -> u8 {
        match self {
            PoseRefusal::Geometry(e) => e.status(),
            _ => GripRecommendation::STATUS_INVALID_INPUT,
        }
    }
}

/// Answers pose candidates: the closing axis, and the meshes loaded so far (each file at each
/// scale once, `package://` through the ament index it was made with).
#[derive(Debug, Clone)]
pub struct PoseAnswerer {
    closing_axis: ClosingAxis,
    meshes: Arc<MeshCache>,
}

impl PoseAnswerer {
    /// Closing along `closing_axis`, `package://` resolved through `index`.
    pub fn new(closing_axis: ClosingAxis, index: AmentIndex) -> Self {
        Self::sharing(
            closing_axis,
            Arc::new(MeshCache::new(index, MESH_CACHE_BYTES)),
        )
    }

    /// Closing along `closing_axis`, with the meshes of `meshes` (shared: the node keeps one
    /// cache for its thread and its set thread, whatever the closing axis in force).
    pub(crate) fn sharing(closing_axis: ClosingAxis, meshes: Arc<MeshCache>) -> Self {
        Self {
            closing_axis,
            meshes,
        }
    }

    /// Closing along `closing_axis`, `package://` through `AMENT_PREFIX_PATH`.
    pub(crate) fn from_env(closing_axis: ClosingAxis) -> Self {
        Self::new(closing_axis, AmentIndex::from_env())
    }

    /// The axis the fingers close along.
    pub(crate) fn closing_axis(&self) -> ClosingAxis {
        self.closing_axis
    }

    /// The meshes loaded so far.
    pub fn meshes(&self) -> &MeshCache {
        &self.meshes
    }

    /// The answer to one pose candidate under `rules`.
    pub fn answer(
        &self,
        m: &PoseCandidate,
        settings: &Settings,
        rules: &Rules,
    ) -> PoseRecommendation {
        self.answer_with_object(m, settings, rules).0
    }

    /// [`PoseAnswerer::answer`], and the object with its shape when it could be made (for the
    /// markers that draw it, without making it twice).
    pub(crate) fn answer_with_object(
        &self,
        m: &PoseCandidate,
        settings: &Settings,
        rules: &Rules,
    ) -> (PoseRecommendation, Option<Object>) {
        let target = target_of(m);
        let object = match self.object(&m.object) {
            Ok(object) => object,
            Err(why) => return (target.refused(&why.into()), None),
        };
        let answer = match self.grasp(&m.grasp_pose, &"", m.width, &object, &m.object, &m.gravity) {
            Ok(grasp) => finish(
                answer_one(&target.candidate(&grasp), settings, rules),
                &grasp,
            ),
            Err(why) => target.refused(&why.into()),
        };
        (answer, Some(object))
    }

    /// The spatial candidate a pose candidate's fingers make, or the answer that refuses it
    /// (status 1 or 2): for a caller that answers it among other candidates (`rank`).
    pub fn spatial_candidate(
        &self,
        m: &PoseCandidate,
    ) -> Result<GraspCandidate, Box<GripRecommendation>> {
        self.place(m)
            .map(|(candidate, _)| candidate)
            .map_err(|why| Box::new(target_of(m).refused(&why).recommendation))
    }

    /// [`Self::spatial_candidate`], with what the answer's `message` would say of a contact on
    /// an edge or a vertex (none for faces): for a caller that shows the candidate (`plot`).
    pub(crate) fn spatial_candidate_noted(
        &self,
        m: &PoseCandidate,
    ) -> Result<(GraspCandidate, Vec<String>), Box<GripRecommendation>> {
        match self.place(m) {
            Ok((candidate, grasp)) => Ok((candidate, feature_notes(&grasp))),
            Err(why) => Err(Box::new(target_of(m).refused(&why).recommendation)),
        }
    }

    /// The candidate and the grasp of a pose candidate.
    fn place(&self, m: &PoseCandidate) -> Result<(GraspCandidate, Grasp), Refused> {
        let object = self.object(&m.object)?;
        let grasp = self.grasp(&m.grasp_pose, &"", m.width, &object, &m.object, &m.gravity)?;
        Ok((target_of(m).candidate(&grasp), grasp))
    }

    /// The answer to a set: its object's shape once, each pose answered against it, ranked as a
    /// [`GraspCandidateSet`] is.
    pub fn answer_set(
        &self,
        set: &PoseCandidateSet,
        settings: &Settings,
        rules: &Rules,
    ) -> PoseRecommendationSet {
        self.answer_set_with(set, rules, |candidates| {
            answer_set(candidates, settings, rules)
        })
        .0
    }

    /// [`PoseAnswerer::answer_set`] with the set of spatial candidates the poses make answered
    /// by `answer` (the node's set thread answers it within `max_set_time`:
    /// `answer_set_within`). `answer` gets a candidate per pose, a pose the geometry refused as
    /// an empty candidate (refused by the solver, and then answered with the geometry's
    /// refusal). The object comes back too when it could be made, for the markers.
    pub(crate) fn answer_set_with(
        &self,
        set: &PoseCandidateSet,
        rules: &Rules,
        answer: impl FnOnce(&GraspCandidateSet) -> GripRecommendationSet,
    ) -> (PoseRecommendationSet, Option<Object>) {
        // A set refused whole (too large) is not worth the geometry.
        let object = (set.poses.len() <= rules.max_set_size)
            .then(|| self.object(&set.object).map_err(Refused::from));
        self.answer_set_on(set, object, answer)
    }

    /// [`PoseAnswerer::answer_set_with`] on `object`, the set's object made (or refused) by the
    /// caller (the node's set thread makes it on a loader thread, within `max_set_time`); `None`
    /// for a set refused whole as too large.
    pub(crate) fn answer_set_on(
        &self,
        set: &PoseCandidateSet,
        object: Option<Result<Object, Refused>>,
        answer: impl FnOnce(&GraspCandidateSet) -> GripRecommendationSet,
    ) -> (PoseRecommendationSet, Option<Object>) {
        let target = |id| Target {
            header: &set.header,
            id,
            object: &set.object,
            gravity: &set.gravity,
        };
        let placed: Vec<Result<Grasp, Refused>> = match &object {
            None => Vec::new(),
            Some(object) => set
                .poses
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let object = object.as_ref().map_err(Refused::clone)?;
                    // The fields' names are written out only for a refusal, not for every pose.
                    let prefix = &format_args!("poses[{i}].");
                    self.grasp(
                        &p.grasp_pose,
                        prefix,
                        p.width,
                        object,
                        &set.object,
                        &set.gravity,
                    )
                    .map_err(Refused::from)
                })
                .collect(),
        };
        let candidates = if placed.is_empty() {
            // As many as the poses, for answer_set to refuse the set as too large (or to answer
            // an empty one).
            vec![GraspCandidate::default(); set.poses.len()]
        } else {
            set.poses
                .iter()
                .zip(&placed)
                .map(|(p, g)| match g {
                    Ok(grasp) => target(&p.id).candidate(grasp),
                    // Refused below; the solver refuses it too, so it is never ranked.
                    Err(_) => GraspCandidate {
                        header: set.header.clone(),
                        id: p.id.clone(),
                        ..GraspCandidate::default()
                    },
                })
                .collect()
        };
        let answered = answer(&GraspCandidateSet {
            header: set.header.clone(),
            id: set.id.clone(),
            candidates,
            max_grip_force: set.max_grip_force,
        });
        let recommendations = answered
            .recommendations
            .into_iter()
            .zip(set.poses.iter().zip(&placed))
            .map(|(reply, (p, g))| match g {
                Ok(grasp) => finish(reply, grasp),
                Err(why) => target(&p.id).refused(why),
            })
            .collect();
        let reply = PoseRecommendationSet {
            header: answered.header,
            set_id: answered.set_id,
            recommendations,
            ranking: answered.ranking,
            ranked_by: answered.ranked_by,
            status: answered.status,
            message: answered.message,
        };
        (reply, object.and_then(Result::ok))
    }

    /// The object's pose and shape, checked: for the markers that draw it.
    pub(crate) fn object(&self, o: &GraspObject) -> Result<Object, PoseRefusal> {
        let pose = isometry(&o.pose, &"object.pose")?;
        let scale = [o.scale.x, o.scale.y, o.scale.z];
        let mesh_given = !o.mesh.is_empty()
            || !o.inline_mesh.triangles.is_empty()
            || !o.inline_mesh.vertices.is_empty();
        if mesh_given {
            check_scale(scale)?;
        }
        let mut given = Vec::new();
        if !o.mesh.is_empty() {
            given.push("mesh");
        }
        if !o.inline_mesh.triangles.is_empty() || !o.inline_mesh.vertices.is_empty() {
            given.push("inline_mesh");
        }
        if o.primitive.kind != 0 || !o.primitive.dimensions.is_empty() {
            given.push("primitive");
        }
        let shape: Shape = match given.as_slice() {
            ["mesh"] => self.meshes.get(&o.mesh, scale)?.into(),
            ["inline_mesh"] => {
                let vertices: Vec<[f64; 3]> = o
                    .inline_mesh
                    .vertices
                    .iter()
                    .map(|v| [v.x, v.y, v.z])
                    .collect();
                let triangles: Vec<[u32; 3]> = o
                    .inline_mesh
                    .triangles
                    .iter()
                    .map(|t| t.vertex_indices)
                    .collect();
                grasp_orient_geometry::Mesh::from_triangles(
                    "inline_mesh",
                    &vertices,
                    &triangles,
                    scale,
                )?
                .into()
            }
            ["primitive"] => {
                if scale != [1.0; 3] {
                    return Err(PoseRefusal::PrimitiveScale { scale });
                }
                Primitive::from_shape_msgs(o.primitive.kind, &o.primitive.dimensions)?.into()
            }
            _ => {
                return Err(PoseRefusal::Shapes {
                    given: given.join(", "),
                })
            }
        };
        Ok(Object { pose, shape })
    }

    /// The contacts and centre of mass of one gripper pose on the object; `prefix` is what the
    /// pose's own fields' paths start with (empty, or `poses[i].` in a set).
    fn grasp(
        &self,
        tool: &Pose,
        prefix: &dyn Display,
        width: f64,
        object: &Object,
        o: &GraspObject,
        gravity: &Vector3,
    ) -> Result<Grasp, PoseRefusal> {
        let c = &o.center_of_mass;
        let given = if o.has_center_of_mass {
            for (axis, v) in [("x", c.x), ("y", c.y), ("z", c.z)] {
                coordinate(&format_args!("object.center_of_mass.{axis}"), v)?;
            }
            Some(Point3::new(c.x, c.y, c.z))
        } else if (c.x, c.y, c.z) != (0.0, 0.0, 0.0) {
            return Err(PoseRefusal::CenterOfMassFlag);
        } else {
            None
        };
        let tool_pose = isometry(tool, &format_args!("{prefix}grasp_pose"))?;
        // A width not finite or not positive is the geometry's to refuse (it names `width`).
        if width.is_finite() && width > MAX_WIDTH {
            return Err(PoseRefusal::Number {
                field: format!("{prefix}width"),
                fault: NumberFault::Above {
                    value: width,
                    limit: MAX_WIDTH,
                    unit: " m",
                },
            });
        }
        let gripper = GripperPose {
            tool_pose,
            width,
            closing_axis: self.closing_axis,
        };
        let grasp = grasp_from_pose(&gripper, object, given).map_err(|e| match e {
            GeometryError::StartsInside { .. } => units_hint(e, &gripper, object, o),
            e => e.into(),
        })?;
        check_object_numbers(o, gravity)?;
        Ok(grasp)
    }
}

/// A refusal as an answer gives it: its status and words (the geometry's errors hold an
/// `io::Error`, which does not clone, and a set's object refused is every pose's refusal).
#[derive(Debug, Clone)]
pub(crate) struct Refused {
    /// The answer's status.
    pub status: u8,
    /// Its message.
    pub message: String,
}

impl From<PoseRefusal> for Refused {
    fn from(e: PoseRefusal) -> Self {
        Refused {
            status: e.status(),
            message: e.to_string(),
        }
    }
}

/// A pose candidate's header, id, object and gravity.
fn target_of(m: &PoseCandidate) -> Target<'_> {
    Target {
        header: &m.header,
        id: &m.id,
        object: &m.object,
        gravity: &m.gravity,
    }
}

/// What a candidate of a pose shares with its set: header, object and gravity, and its own id.
struct Target<'a> {
    header: &'a Header,
    id: &'a CompactString,
    object: &'a GraspObject,
    gravity: &'a Vector3,
}

impl Target<'_> {
    /// The spatial candidate the fingers make.
    fn candidate(&self, grasp: &Grasp) -> GraspCandidate {
        let [c1, c2] = &grasp.contacts;
        GraspCandidate {
            header: self.header.clone(),
            id: self.id.clone(),
            contact_1: point(&c1.point),
            contact_2: point(&c2.point),
            normal_1: vector(&c1.normal),
            normal_2: vector(&c2.normal),
            friction_1: self.object.friction,
            friction_2: self.object.friction,
            center_of_mass: point(&grasp.center_of_mass),
            mass: self.object.mass,
            gravity: self.gravity.clone(),
            model: GraspCandidate::MODEL_SPATIAL,
            ..GraspCandidate::default()
        }
    }

    /// The answer to a pose the geometry refuses: status 1 or 2, no geometry (NaN).
    fn refused(&self, why: &Refused) -> PoseRecommendation {
        let stub = GraspCandidate {
            header: self.header.clone(),
            id: self.id.clone(),
            ..GraspCandidate::default()
        };
        without_geometry(
            if why.status == GripRecommendation::STATUS_NO_FORCE_CLOSURE {
                no_closure(&stub, &why.message)
            } else {
                invalid(&stub, &why.message)
            },
        )
    }
}

/// The answer to a pose set whose members were not cast (refused whole, busy, or echoed): `reply`,
/// an answer to as many empty candidates as `set` has poses, with the poses' ids and no geometry.
pub(crate) fn pose_set_without_geometry(
    set: &PoseCandidateSet,
    reply: GripRecommendationSet,
) -> PoseRecommendationSet {
    let recommendations = reply
        .recommendations
        .into_iter()
        .zip(&set.poses)
        .map(|(mut r, p)| {
            r.candidate_id = p.id.clone();
            without_geometry(r)
        })
        .collect();
    PoseRecommendationSet {
        header: reply.header,
        set_id: reply.set_id,
        recommendations,
        ranking: reply.ranking,
        ranked_by: reply.ranked_by,
        status: reply.status,
        message: reply.message,
    }
}

/// The set of empty candidates, one per pose, that stands for `set` where its poses are not cast
/// (see [`pose_set_without_geometry`]).
pub(crate) fn uncast(set: &PoseCandidateSet) -> GraspCandidateSet {
    GraspCandidateSet {
        header: set.header.clone(),
        id: set.id.clone(),
        candidates: set
            .poses
            .iter()
            .map(|p| GraspCandidate {
                header: set.header.clone(),
                id: p.id.clone(),
                ..GraspCandidate::default()
            })
            .collect(),
        max_grip_force: set.max_grip_force,
    }
}

/// The answer to a pose candidate refused before it had contacts: the refusal, and NaN for the
/// geometry.
pub(crate) fn without_geometry(recommendation: GripRecommendation) -> PoseRecommendation {
    let nan = Point {
        x: f64::NAN,
        y: f64::NAN,
        z: f64::NAN,
    };
    let nan_vector = Vector3 {
        x: f64::NAN,
        y: f64::NAN,
        z: f64::NAN,
    };
    PoseRecommendation {
        recommendation,
        contact_1: nan.clone(),
        contact_2: nan.clone(),
        normal_1: nan_vector.clone(),
        normal_2: nan_vector,
        center_of_mass: nan,
    }
}

/// The answer with the grasp's geometry, and a note on a contact at an edge or a vertex.
fn finish(mut reply: GripRecommendation, grasp: &Grasp) -> PoseRecommendation {
    let [c1, c2] = &grasp.contacts;
    let notes = feature_notes(grasp);
    if !notes.is_empty() {
        let mut message = reply.message.to_string();
        for note in notes {
            if !message.is_empty() {
                message.push_str("; ");
            }
            message.push_str(&note);
        }
        reply.message = message.into();
    }
    PoseRecommendation {
        recommendation: reply,
        contact_1: point(&c1.point),
        contact_2: point(&c2.point),
        normal_1: vector(&c1.normal),
        normal_2: vector(&c2.normal),
        center_of_mass: point(&grasp.center_of_mass),
    }
}

/// What `message` says of the contacts on an edge or a vertex, `contact_1` first.
fn feature_notes(grasp: &Grasp) -> Vec<String> {
    let [c1, c2] = &grasp.contacts;
    [("contact_1", c1), ("contact_2", c2)]
        .into_iter()
        .filter_map(|(name, c)| feature_note(name, c))
        .collect()
}

/// What `message` says of a contact on an edge or a vertex.
fn feature_note(name: &str, c: &Contact) -> Option<String> {
    let feature = match c.feature {
        Feature::Face => return None,
        Feature::Edge => "an edge",
        Feature::Vertex => "a vertex",
    };
    Some(format!(
        "{name} lies on {feature} of the object: its normal is the pseudo-normal there \
         (docs/poses.md)"
    ))
}

/// A pose as an isometry, its quaternion normalised. `field` names the pose: each coordinate of
/// its position must be finite and within the solver's coordinate limit, each component of its
/// quaternion finite, and the quaternion not zero.
///
/// # Normalisation
/// A quaternion is a rotation at any length: it is divided by its norm. The norm of one whose
/// largest component `m` lies outside `1e-150..=1e150` is first brought near 1 by an exact power
/// of two (`2^-floor(log2 m)`), since squaring its components would overflow (norm 1e200: inf)
/// or underflow (norm 1e-200: 0); one inside is divided by its norm as it is, bit for bit as
/// before.
fn isometry(p: &Pose, field: &dyn Display) -> Result<Isometry3<f64>, PoseRefusal> {
    let t = &p.position;
    for (axis, v) in [("x", t.x), ("y", t.y), ("z", t.z)] {
        coordinate(&format_args!("{field}.position.{axis}"), v)?;
    }
    let o = &p.orientation;
    for (axis, v) in [("x", o.x), ("y", o.y), ("z", o.z), ("w", o.w)] {
        if !v.is_finite() {
            return Err(PoseRefusal::Number {
                field: format!("{field}.orientation.{axis}"),
                fault: NumberFault::NotFinite,
            });
        }
    }
    let q = Quaternion::new(o.w, o.x, o.y, o.z);
    let largest = q.coords.amax();
    if largest == 0.0 {
        return Err(PoseRefusal::Orientation {
            field: format!("{field}.orientation"),
            norm: 0.0,
        });
    }
    let q = if SQUARE_SAFE.contains(&largest) {
        q
    } else {
        let k = -(largest.log2().floor() as i32);
        Quaternion::from(q.coords.map(|c| times_pow2(c, k)))
    };
    Ok(Isometry3::from_parts(
        Translation3::new(t.x, t.y, t.z),
        UnitQuaternion::from_quaternion(q),
    ))
}

/// A coordinate of a pose candidate, m: finite and within the solver's coordinate limit.
fn coordinate(field: &dyn Display, v: f64) -> Result<(), PoseRefusal> {
    let fault = if !v.is_finite() {
        NumberFault::NotFinite
    } else if v.abs() > MAX_COORDINATE {
        NumberFault::Above {
            value: v,
            limit: MAX_COORDINATE,
            unit: " m",
        }
    } else {
        return Ok(());
    };
    Err(PoseRefusal::Number {
        field: field.to_string(),
        fault,
    })
}

/// A mesh's scale: each axis's factor within `[MIN_SCALE, MAX_SCALE]`. A factor that is zero or
/// negative is left to the geometry, which names the resource and the scale.
fn check_scale(scale: [f64; 3]) -> Result<(), PoseRefusal> {
    for (axis, v) in ["x", "y", "z"].into_iter().zip(scale) {
        let fault = if !v.is_finite() {
            NumberFault::NotFinite
        } else if v > MAX_SCALE {
            NumberFault::Above {
                value: v,
                limit: MAX_SCALE,
                unit: "",
            }
        } else if v > 0.0 && v < MIN_SCALE {
            NumberFault::Below {
                value: v,
                minimum: MIN_SCALE,
            }
        } else {
            continue;
        };
        return Err(PoseRefusal::Number {
            field: format!("object.scale.{axis}"),
            fault,
        });
    }
    Ok(())
}

/// The object's friction and mass as the solver checks them, named as the pose candidate's
/// fields (the spatial candidate gives `object.friction` to both contacts, and would name
/// `friction_1`), and the weight they make with `gravity` once gravity is within the solver's
/// limits (otherwise the solver names the gravity field at fault, `gravity.z`, the same path).
fn check_object_numbers(o: &GraspObject, gravity: &Vector3) -> Result<(), PoseRefusal> {
    check_friction("object.friction", o.friction)?;
    let mass = check_mass("object.mass", o.mass)?;
    let g = V3::new(gravity.x, gravity.y, gravity.z);
    let gravity_checked = g.iter().all(|c| c.abs() <= MAX_GRAVITY) && g != V3::zeros();
    if gravity_checked {
        check_weight("object.mass", mass, &g)?;
    }
    Ok(())
}

/// A finger's refusal for starting inside the object, with a hint about units when the object is
/// a mesh [`UNITS_HINT_RATIO`] times wider along the closing line than the opening.
///
/// The extent is the spread of the mesh's vertices along the closing axis `b` in the object
/// frame, `max(v·b) − min(v·b)`: the object's own length along the line the fingers close on.
fn units_hint(
    e: GeometryError,
    gripper: &GripperPose,
    object: &Object,
    o: &GraspObject,
) -> PoseRefusal {
    let Shape::Mesh(mesh) = &object.shape else {
        return e.into();
    };
    let b_header = gripper.tool_pose.rotation * gripper.closing_axis.unit().into_inner();
    let b = object.pose.rotation.inverse() * b_header;
    let (lo, hi) = mesh
        .corners()
        .flatten()
        .map(|v| V3::from(v).dot(&b))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
    let ratio = (hi - lo) / gripper.width;
    if UNITS_HINT_RATIO.contains(&ratio) {
        PoseRefusal::StartsInsideUnits {
            source: e,
            ratio,
            unit_scale: [o.scale.x, o.scale.y, o.scale.z] == [1.0; 3],
        }
    } else {
        e.into()
    }
}

fn point(p: &Point3<f64>) -> Point {
    Point {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

fn vector(v: &nalgebra::UnitVector3<f64>) -> Vector3 {
    Vector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{GraspPose, MeshTriangle, Quaternion};

    fn pose(x: f64, y: f64, z: f64) -> Pose {
        Pose {
            position: Point { x, y, z },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            },
        }
    }

    /// A 40 mm cube in millimetres, corner at the origin: its corners and its triangles, two to
    /// a face, wound outward.
    fn cube_mm() -> ([[f64; 3]; 8], Vec<[u32; 3]>) {
        let corners = std::array::from_fn(|i| {
            [
                40.0 * (i & 1) as f64,
                40.0 * ((i >> 1) & 1) as f64,
                40.0 * ((i >> 2) & 1) as f64,
            ]
        });
        let quads: [[u32; 4]; 6] = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (corners, triangles)
    }

    /// [`cube_mm`] as an ASCII STL.
    fn write_cube(path: &std::path::Path) {
        let (corners, triangles) = cube_mm();
        let mut text = String::from("solid cube\n");
        for t in triangles {
            text.push_str(" facet normal 0 0 0\n  outer loop\n");
            for i in t {
                let [x, y, z] = corners[i as usize];
                text.push_str(&format!("   vertex {x} {y} {z}\n"));
            }
            text.push_str("  endloop\n endfacet\n");
        }
        text.push_str("endsolid cube\n");
        std::fs::write(path, text).expect("write the cube");
    }

    fn set_on(mesh: &str, poses: usize) -> PoseCandidateSet {
        PoseCandidateSet {
            id: "set".into(),
            object: GraspObject {
                pose: pose(0.0, 0.0, 0.0),
                mesh: mesh.into(),
                scale: Vector3 {
                    x: 0.001,
                    y: 0.001,
                    z: 0.001,
                },
                mass: 0.2,
                friction: 0.8,
                ..GraspObject::default()
            },
            poses: (0..poses)
                .map(|i| GraspPose {
                    id: format!("p{i}").into(),
                    grasp_pose: pose(0.02, 0.02, 0.01 + 0.004 * i as f64),
                    width: 0.1,
                })
                .collect(),
            gravity: Vector3 {
                x: 0.0,
                y: 0.0,
                z: -9.81,
            },
            ..PoseCandidateSet::default()
        }
    }

    #[test]
    fn a_set_loads_its_mesh_once_and_a_refused_object_refuses_every_pose() {
        let dir = tempfile::tempdir().expect("a folder");
        let path = dir.path().join("cube.stl");
        write_cube(&path);
        let answerer = PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default());
        let set = set_on(&path.display().to_string(), 5);
        let (settings, rules) = (Settings::default(), Rules::default());
        let answer = answerer.answer_set(&set, &settings, &rules);
        assert_eq!(answer.recommendations.len(), 5);
        assert_eq!(answer.ranking.len(), 5, "{answer:?}");
        for r in &answer.recommendations {
            assert_eq!(r.recommendation.status, 0, "{}", r.recommendation.message);
            assert!((r.contact_1.y - 0.0).abs() < 1e-15 && (r.contact_2.y - 0.04).abs() < 1e-15);
            assert!((r.center_of_mass.z - 0.02).abs() < 1e-15);
        }
        answerer.answer_set(&set, &settings, &rules);
        assert_eq!(answerer.meshes().loads(), 1);

        let missing = answerer.answer_set(&set_on("/no/such/cube.stl", 3), &settings, &rules);
        assert!(missing.ranking.is_empty());
        for r in &missing.recommendations {
            assert_eq!(r.recommendation.status, 2);
            assert!(r.recommendation.message.contains("/no/such/cube.stl"));
            assert!(r.contact_1.x.is_nan());
        }
    }

    #[test]
    fn a_set_too_large_is_refused_before_any_mesh_is_loaded() {
        let dir = tempfile::tempdir().expect("a folder");
        let path = dir.path().join("cube.stl");
        write_cube(&path);
        let answerer = PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default());
        let rules = Rules {
            max_set_size: 2,
            ..Rules::default()
        };
        let set = set_on(&path.display().to_string(), 3);
        let answer = answerer.answer_set(&set, &Settings::default(), &rules);
        assert_eq!(answer.status, PoseRecommendationSet::STATUS_TOO_LARGE);
        assert!(answer.recommendations.is_empty());
        assert_eq!(answerer.meshes().loads(), 0);
    }

    #[test]
    fn an_inline_mesh_is_the_same_cube() {
        let answerer = PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default());
        let mut set = set_on("", 1);
        let (corners, triangles) = cube_mm();
        set.object.inline_mesh.vertices =
            corners.iter().map(|&[x, y, z]| Point { x, y, z }).collect();
        set.object.inline_mesh.triangles = triangles
            .into_iter()
            .map(|vertex_indices| MeshTriangle { vertex_indices })
            .collect();
        let r = answerer.answer(
            &PoseCandidate {
                id: "inline".into(),
                grasp_pose: set.poses[0].grasp_pose.clone(),
                width: 0.1,
                object: set.object.clone(),
                gravity: set.gravity.clone(),
                ..PoseCandidate::default()
            },
            &Settings::default(),
            &Rules::default(),
        );
        assert_eq!(r.recommendation.status, 0, "{}", r.recommendation.message);
        assert!((r.contact_2.y - 0.04).abs() < 1e-15);
        assert_eq!((r.normal_1.y, r.normal_2.y), (1.0, -1.0));
    }
}
