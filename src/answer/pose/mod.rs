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

mod checks;
mod refusal;
mod tool;

use super::reply::no_closure;
use super::sets::SetAnswer;
use super::{answer_one, answer_set, Rules};
use crate::msg::{
    invalid, CompactString, GraspCandidate, GraspCandidateSet, GraspObject, GripRecommendation,
    GripRecommendationSet, Header, Point, Pose, PoseCandidate, PoseCandidateSet,
    PoseRecommendation, PoseRecommendationSet, Vector3,
};
use crate::solver::Settings;
use checks::{check_object_numbers, check_scale, coordinate, isometry, point, units_hint, vector};
use grasp_orient_geometry::{
    grasp_from_pose, AmentIndex, ClosingAxis, Contact, Feature, GeometryError, Grasp, GripperPose,
    MeshCache, Object, Primitive, Shape,
};
use nalgebra::Point3;
use refusal::MAX_WIDTH;
pub(crate) use refusal::{NumberFault, PoseRefusal, Refused};
use std::fmt::Display;
use std::sync::Arc;
use tool::{no_tool_pose, tool_pose};

/// The most bytes of meshes a [`PoseAnswerer`] keeps loaded (least recently used dropped first).
pub const MESH_CACHE_BYTES: usize = 512 << 20;

/// Answers pose candidates: the closing axis, and the meshes loaded so far (each file at each
/// scale once, `package://` through the ament index it was made with).
#[derive(Debug, Clone)]
pub struct PoseAnswerer {
    closing_axis: ClosingAxis,
    meshes: Arc<MeshCache>,
    /// `max_inline_mesh_triangles` ([`PoseAnswerer::bounding_inline`]); no bound by default.
    max_inline: usize,
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
            max_inline: usize::MAX,
        }
    }

    /// An inline mesh of more than `max_triangles` triangles, or more than three vertices per
    /// allowed triangle, refused before anything of it is indexed or even checked
    /// (parameter `max_inline_mesh_triangles`: `Config::answering`, the node's versions and
    /// `replay`'s settings records apply it, so that the node, `solve` and `replay` answer
    /// alike; a `PoseAnswerer` made without a config has no bound). The words name
    /// the bound, not the mesh's count, so that a mesh the node decoded only up to the bound
    /// (`msg::limit_inline_mesh_decoding`) is refused with the same words, and a recording of it
    /// replays to the same answer.
    pub(crate) fn bounding_inline(mut self, max_triangles: i64) -> Self {
        self.max_inline = usize::try_from(max_triangles).unwrap_or(usize::MAX);
        self
    }

    /// Why `o`'s inline mesh is refused before it is indexed ([`PoseAnswerer::bounding_inline`]).
    pub(crate) fn inline_too_large(&self, o: &GraspObject) -> Option<PoseRefusal> {
        let mesh = &o.inline_mesh;
        let max = self.max_inline;
        if mesh.triangles.len() > max {
            return Some(PoseRefusal::InlineTriangles { max });
        }
        let max_vertices = max.saturating_mul(3);
        (mesh.vertices.len() > max_vertices).then_some(PoseRefusal::InlineVertices { max_vertices })
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
    pub(crate) fn answer(
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
                &m.grasp_pose,
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
    pub(crate) fn answer_set(
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
                Ok(grasp) => finish(reply, grasp, &p.grasp_pose),
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
        if let Some(why) = self.inline_too_large(o) {
            return Err(why);
        }
        // Only the node has TF, and it turns the pose into the header frame (emptying
        // frame_id) before the answer; here a pose in another frame would be taken as one in the
        // header frame, a wrong answer given as a right one.
        if !o.frame_id.is_empty() {
            return Err(PoseRefusal::ObjectFrame {
                frame: o.frame_id.to_string(),
            });
        }
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
/// geometry and the tool pose (with the recommendation's header).
pub(crate) fn without_geometry(recommendation: GripRecommendation) -> PoseRecommendation {
    let tool_pose = no_tool_pose(&recommendation.header);
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
        tool_pose,
    }
}

/// The answer with the grasp's geometry, the tool pose `tool` (the candidate's gripper pose)
/// turned by the answer's rotation about the grasp centre ([`tool::tool_pose`]), and a note on a
/// contact at an edge or a vertex.
fn finish(mut reply: GripRecommendation, grasp: &Grasp, tool: &Pose) -> PoseRecommendation {
    let [c1, c2] = &grasp.contacts;
    // The pose was checked when the grasp was made from it: this is that isometry again.
    let carried = match isometry(tool, &"grasp_pose") {
        Ok(tool) => tool_pose(&reply.header, &tool, grasp, &reply.rotation),
        Err(_) => no_tool_pose(&reply.header),
    };
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
        tool_pose: carried,
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

impl SetAnswer for PoseRecommendationSet {
    fn set_id(&self) -> &CompactString {
        &self.set_id
    }
    fn status(&self) -> u8 {
        self.status
    }
    fn message(&self) -> &str {
        &self.message
    }
    fn members(&self) -> Vec<&GripRecommendation> {
        self.recommendations
            .iter()
            .map(|p| &p.recommendation)
            .collect()
    }
    fn ranked(&self) -> (usize, &str) {
        (self.ranking.len(), &self.ranked_by)
    }
    fn refuse(&mut self, why: &str) {
        self.status = GripRecommendationSet::STATUS_INVALID_INPUT;
        self.message = why.into();
        self.recommendations.clear();
        self.ranking.clear();
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

    /// `cube_mm`'s cube as an inline mesh.
    fn inline_cube_mm() -> crate::msg::Mesh {
        let (corners, triangles) = cube_mm();
        crate::msg::Mesh {
            vertices: corners.iter().map(|&[x, y, z]| Point { x, y, z }).collect(),
            triangles: triangles
                .into_iter()
                .map(|vertex_indices| MeshTriangle { vertex_indices })
                .collect(),
        }
    }

    #[test]
    fn an_inline_mesh_is_the_same_cube() {
        let answerer = PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default());
        let mut set = set_on("", 1);
        set.object.inline_mesh = inline_cube_mm();
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

    /// An inline mesh beyond `max_inline_mesh_triangles` is refused before it is looked at, one
    /// triangle beyond or thousands, with the same words (the node decodes no more than one
    /// beyond: `msg::limit_inline_mesh_decoding`), alone and in a set; at the bound it is
    /// answered; vertices beyond three per allowed triangle are refused too; no bound without a
    /// config, and `Config::answering` applies the config's.
    #[test]
    fn an_inline_mesh_beyond_the_bound_is_refused_in_words_without_its_count() {
        let mut set = set_on("", 2);
        set.object.inline_mesh = inline_cube_mm();
        let single = |object: &GraspObject| PoseCandidate {
            id: "inline".into(),
            grasp_pose: set.poses[0].grasp_pose.clone(),
            width: 0.1,
            object: object.clone(),
            gravity: set.gravity.clone(),
            ..PoseCandidate::default()
        };
        let (settings, rules) = (Settings::default(), Rules::default());
        let n = set.object.inline_mesh.triangles.len();
        let unbounded = PoseAnswerer::new(ClosingAxis::Y, AmentIndex::default());
        let at = unbounded.clone().bounding_inline(n as i64);
        for answerer in [&unbounded, &at] {
            let r = answerer.answer(&single(&set.object), &settings, &rules);
            assert_eq!(r.recommendation.status, 0, "{}", r.recommendation.message);
        }
        let words = format!(
            "invalid input: object.inline_mesh has more triangles than max_inline_mesh_triangles \
             ({}); send a coarser mesh",
            n - 1
        );
        let below = unbounded.clone().bounding_inline(n as i64 - 1);
        let mut many = set.object.clone();
        let copies: Vec<MeshTriangle> = (0..500)
            .flat_map(|_| many.inline_mesh.triangles.iter().cloned())
            .collect();
        many.inline_mesh.triangles = copies;
        for object in [&set.object, &many] {
            let r = below.answer(&single(object), &settings, &rules);
            assert_eq!(r.recommendation.status, 2);
            assert_eq!(r.recommendation.message, words);
            assert!(r.contact_1.x.is_nan());
            let mut in_set = set.clone();
            in_set.object = object.clone();
            let a = below.answer_set(&in_set, &settings, &rules);
            assert!(a.ranking.is_empty());
            for r in &a.recommendations {
                assert_eq!(r.recommendation.status, 2);
                assert_eq!(r.recommendation.message, words);
            }
        }
        // Vertices: three per allowed triangle at most.
        let mut soup = set.object.clone();
        let extra = soup.inline_mesh.vertices[0].clone();
        soup.inline_mesh.vertices.resize(3 * n + 1, extra);
        let r = at.answer(&single(&soup), &settings, &rules);
        assert_eq!(r.recommendation.status, 2);
        assert_eq!(
            r.recommendation.message,
            format!(
                "invalid input: object.inline_mesh has more vertices than 3 x \
                 max_inline_mesh_triangles ({})",
                3 * n
            )
        );
        // The config's bound, through Config::answering.
        let config = crate::config::Config {
            max_inline_mesh_triangles: n as i64 - 1,
            ..Default::default()
        };
        let with = config.answering(unbounded.clone()).expect("valid");
        let r = with.answer::<crate::kind::Poses>(&single(&set.object));
        assert_eq!(r.recommendation.message, words);
    }
}
