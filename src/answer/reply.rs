//! A solver's answer as the published reply: the pose from the solver's recommendation, the
//! forces from a [`Forces`] (the one place they become wire fields), and the refusal of a valid
//! grasp that no orientation holds.
//!
//! The spatial answer fills the same fields in the spatial reading of the message
//! (`docs/spatial.md`): the smallest 3D rotation as `wrist_rotation` (its angle) and `rotation`,
//! the recommended 3D gravity direction, the planar answer in the grasp plane Π for the rest, and
//! in `message` what the caller must know though the grasp holds: the object swings at its
//! current pose, the answer is sensitive to the centre of mass.

use super::forces::Forces;
use crate::msg::convert::refused;
use crate::msg::{CompactString, GraspCandidate, GripRecommendation, Quaternion, Vector3};
use crate::solver::{planar, spatial};
use compact_str::ToCompactString as _;

/// The answer to a valid grasp that no orientation holds: status 1, `why` naming the contact,
/// the current-pose forces infinite.
pub(crate) fn no_closure(m: &GraspCandidate, why: &dyn std::fmt::Display) -> GripRecommendation {
    let mut out = refused(
        m,
        GripRecommendation::STATUS_NO_FORCE_CLOSURE,
        why.to_compact_string(),
    );
    Forces::NO_CLOSURE.write(&mut out);
    out
}

/// The answer with the pose of the planar recommendation `r` and the forces `forces`.
pub(crate) fn recommended(
    m: &GraspCandidate,
    r: &planar::Recommendation,
    forces: &Forces,
) -> GripRecommendation {
    let half = 0.5 * r.wrist_rotation;
    let mut out = GripRecommendation {
        header: m.header.clone(),
        candidate_id: m.id.clone(),
        status: GripRecommendation::STATUS_OK,
        message: CompactString::default(),
        wrist_rotation: r.wrist_rotation,
        rotation: Quaternion {
            x: 0.0,
            y: 0.0,
            z: half.sin(),
            w: half.cos(),
        },
        gravity_direction: Vector3 {
            x: r.gravity_direction.x,
            y: r.gravity_direction.y,
            z: 0.0,
        },
        gravity_angle: r.gravity_angle,
        grasp_case: CompactString::const_new(r.grasp_case.name()),
        local_minima: r.local_minima.iter().map(|l| l.gravity_angle).collect(),
        local_minima_power: r.local_minima.iter().map(|l| l.power).collect(),
        local_minima_labels: r.local_minima.iter().map(|l| label(l.label)).collect(),
        objective: CompactString::const_new(r.objective.name()),
        recommended_label: label(r.recommended_label),
        candidate_c: r.candidate_c as u8,
        // `wrist_rotation` is signed about +z.
        rotation_axis: Vector3 {
            x: 0.0,
            y: 0.0,
            z: 1.0,
        },
        // The forces: below, from `forces`.
        ..GripRecommendation::default()
    };
    forces.write(&mut out);
    out
}

/// A paper candidate's name, `""` for none; inline, without a heap block.
fn label(l: Option<planar::PaperCandidate>) -> CompactString {
    l.map_or(CompactString::default(), |x| {
        CompactString::const_new(x.name())
    })
}

/// The answer to a spatial grasp that holds: the planar answer in Π, with the 3D rotation, the
/// recommended 3D gravity direction, and the notes on the current pose and the centre of mass;
/// the forces `forces`.
pub(crate) fn spatial_recommended(
    m: &GraspCandidate,
    r: &spatial::Recommendation,
    forces: &Forces,
) -> GripRecommendation {
    let mut out = recommended(m, &r.planar, forces);
    let [x, y, z, w] = r.quaternion();
    out.wrist_rotation = r.rotation_angle;
    out.rotation = Quaternion { x, y, z, w };
    let d = &r.gravity_direction;
    out.gravity_direction = Vector3 {
        x: d.x,
        y: d.y,
        z: d.z,
    };
    let k = &r.rotation_axis;
    out.rotation_axis = Vector3 {
        x: k.x,
        y: k.y,
        z: k.z,
    };
    let notes: Vec<String> = [r.current_pose.note(), r.axis.note().map(str::to_string)]
        .into_iter()
        .flatten()
        .collect();
    out.message = notes.join("; ").into();
    out
}
