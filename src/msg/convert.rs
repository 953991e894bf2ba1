//! Wire candidate → solver input, and the reply that carries no answer (a refusal): conversions
//! only. Which solver answers a candidate, with which tolerances, and how its answer fills the
//! reply, is the answer layer's (`crate::answer`, `src/answer/reply.rs`).
//!
//! A planar candidate (`model` 0) uses the x-y components of its points and vectors; a spatial one
//! (`model` 1) all three ([`spatial::Candidate`]).

use super::{CompactString, GraspCandidate, GripRecommendation, Point, Pose, Quaternion, Vector3};
use crate::solver::{
    planar::{robust::Uncertainty, Candidate},
    spatial, InvalidInput,
};
use nalgebra::Vector2;

/// Longest accepted `id` and `header.frame_id`, bytes.
pub(crate) const MAX_TEXT_BYTES: usize = 1024;

/// What makes a candidate message unusable: its own limits (text lengths, `model`), checked before
/// the solver sees it, and the solver's refusal of its values ([`InvalidInput`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MessageLimits {
    /// A text field is longer than `MAX_TEXT_BYTES`.
    #[error("{field} is {len} bytes long; at most {MAX_TEXT_BYTES} are accepted")]
    TooLong {
        /// The field.
        field: &'static str,
        /// Its length, bytes.
        len: usize,
    },
    /// A field the solver ignores (z) is still not a number.
    #[error(transparent)]
    Solver(#[from] InvalidInput),
    /// `model` names no model.
    #[error(
        "model is {value}: it must be 0 (MODEL_PLANAR: the x-y plane) or 1 (MODEL_SPATIAL: 3D)"
    )]
    Model {
        /// The value given.
        value: u8,
    },
}

fn planar(fields: [&'static str; 3], x: f64, y: f64, z: f64) -> Result<Vector2<f64>, InvalidInput> {
    for (field, v) in fields.into_iter().zip([x, y, z]) {
        if !v.is_finite() {
            return Err(InvalidInput::NotFinite { field });
        }
    }
    Ok(Vector2::new(x, y))
}

fn point(fields: [&'static str; 3], p: &Point) -> Result<Vector2<f64>, InvalidInput> {
    planar(fields, p.x, p.y, p.z)
}

fn vector(fields: [&'static str; 3], v: &Vector3) -> Result<Vector2<f64>, InvalidInput> {
    planar(fields, v.x, v.y, v.z)
}

/// The texts of a candidate are within [`MAX_TEXT_BYTES`].
fn check_texts(m: &GraspCandidate) -> Result<(), MessageLimits> {
    for (field, text) in [("id", &m.id), ("header.frame_id", &m.header.frame_id)] {
        if text.len() > MAX_TEXT_BYTES {
            return Err(MessageLimits::TooLong {
                field,
                len: text.len(),
            });
        }
    }
    Ok(())
}

impl TryFrom<&GraspCandidate> for Candidate {
    type Error = MessageLimits;

    fn try_from(m: &GraspCandidate) -> Result<Self, Self::Error> {
        check_texts(m)?;
        Ok(Candidate {
            contact_1: point(["contact_1.x", "contact_1.y", "contact_1.z"], &m.contact_1)?,
            contact_2: point(["contact_2.x", "contact_2.y", "contact_2.z"], &m.contact_2)?,
            normal_1: vector(["normal_1.x", "normal_1.y", "normal_1.z"], &m.normal_1)?,
            normal_2: vector(["normal_2.x", "normal_2.y", "normal_2.z"], &m.normal_2)?,
            friction_1: m.friction_1,
            friction_2: m.friction_2,
            center_of_mass: point(
                ["center_of_mass.x", "center_of_mass.y", "center_of_mass.z"],
                &m.center_of_mass,
            )?,
            mass: m.mass,
            gravity: vector(["gravity.x", "gravity.y", "gravity.z"], &m.gravity)?,
        })
    }
}

/// A rigid transform as a `geometry_msgs/Pose`: its translation and unit quaternion.
impl From<&nalgebra::Isometry3<f64>> for Pose {
    fn from(p: &nalgebra::Isometry3<f64>) -> Self {
        let (t, q) = (&p.translation.vector, &p.rotation);
        Pose {
            position: Point {
                x: t.x,
                y: t.y,
                z: t.z,
            },
            orientation: Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            },
        }
    }
}

fn point3(p: &Point) -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(p.x, p.y, p.z)
}

fn vector3(v: &Vector3) -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(v.x, v.y, v.z)
}

/// Every component as given: the spatial solver checks them all, naming each (`contact_1.z`).
impl TryFrom<&GraspCandidate> for spatial::Candidate {
    type Error = MessageLimits;

    fn try_from(m: &GraspCandidate) -> Result<Self, Self::Error> {
        check_texts(m)?;
        Ok(spatial::Candidate {
            contact_1: point3(&m.contact_1),
            contact_2: point3(&m.contact_2),
            normal_1: vector3(&m.normal_1),
            normal_2: vector3(&m.normal_2),
            friction_1: m.friction_1,
            friction_2: m.friction_2,
            center_of_mass: point3(&m.center_of_mass),
            mass: m.mass,
            gravity: vector3(&m.gravity),
        })
    }
}

/// `text` cut to at most [`MAX_TEXT_BYTES`] at a character boundary, as answers carry it.
pub(crate) fn clip(text: &str) -> &str {
    let mut end = text.len().min(MAX_TEXT_BYTES);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

/// Characters of an id that logs and reports show.
pub(crate) const SHORT_ID_CHARS: usize = 64;

/// An id cut to its first [`SHORT_ID_CHARS`] characters, for logs and reports.
pub(crate) fn short_id(id: &str) -> &str {
    id.char_indices()
        .nth(SHORT_ID_CHARS)
        .map_or(id, |(end, _)| &id[..end])
}

/// A recommendation whose numbers all say "no answer" (NaN), for a refused candidate.
pub(crate) fn refused(
    m: &GraspCandidate,
    status: u8,
    message: CompactString,
) -> GripRecommendation {
    let nan = f64::NAN;
    let mut header = m.header.clone();
    header.frame_id = clip(&header.frame_id).into();
    GripRecommendation {
        header,
        candidate_id: clip(&m.id).into(),
        status,
        message,
        wrist_rotation: nan,
        rotation: Quaternion {
            x: nan,
            y: nan,
            z: nan,
            w: nan,
        },
        gravity_direction: Vector3 {
            x: nan,
            y: nan,
            z: nan,
        },
        gravity_angle: nan,
        gripping_power: nan,
        internal_force: nan,
        contact_forces: [nan; 4],
        gripping_power_current: nan,
        internal_force_current: nan,
        grasp_case: CompactString::default(),
        local_minima: Vec::new(),
        local_minima_power: Vec::new(),
        local_minima_labels: Vec::new(),
        objective: CompactString::default(),
        recommended_label: CompactString::default(),
        candidate_c: GripRecommendation::CANDIDATE_C_OUT_OF_RANGE,
        finger_force: nan,
        finger_force_current: nan,
        rotation_axis: Vector3 {
            x: nan,
            y: nan,
            z: nan,
        },
        gripping_power_nominal: nan,
    }
}

/// The answer to a candidate whose input is bad.
pub(crate) fn invalid(m: &GraspCandidate, why: &dyn std::fmt::Display) -> GripRecommendation {
    refused(
        m,
        GripRecommendation::STATUS_INVALID_INPUT,
        compact_str::format_compact!("invalid input: {why}"),
    )
}

/// The tolerances of a candidate in the planar model: x and y of the box, the mass; the box's z
/// is ignored but must still be a number.
pub(crate) fn planar_uncertainty(m: &GraspCandidate) -> Result<Uncertainty, InvalidInput> {
    let t = &m.center_of_mass_tolerance;
    let fields = [
        "center_of_mass_tolerance.x",
        "center_of_mass_tolerance.y",
        "center_of_mass_tolerance.z",
    ];
    Ok(Uncertainty {
        center_of_mass_tolerance: vector(fields, t)?,
        mass_tolerance: m.mass_tolerance,
    })
}
