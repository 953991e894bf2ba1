//! Wire candidate → solver input, and solver outcome → wire recommendation.

use super::{GraspCandidate, GripRecommendation, Point, Quaternion, Vector3};
use crate::solver::{
    solve_orientation, Candidate, InvalidInput, NoForceClosure, Recommendation, Settings, Verdict,
};
use nalgebra::Vector2;

/// Longest accepted `id` and `header.frame_id`, bytes.
pub const MAX_TEXT_BYTES: usize = 1024;

/// What makes a candidate message unusable before the solver sees it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MessageLimits {
    /// A text field is longer than [`MAX_TEXT_BYTES`].
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

impl TryFrom<&GraspCandidate> for Candidate {
    type Error = MessageLimits;

    fn try_from(m: &GraspCandidate) -> Result<Self, Self::Error> {
        for (field, text) in [("id", &m.id), ("header.frame_id", &m.header.frame_id)] {
            if text.len() > MAX_TEXT_BYTES {
                return Err(MessageLimits::TooLong {
                    field,
                    len: text.len(),
                });
            }
        }
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

/// `text` cut to at most [`MAX_TEXT_BYTES`] at a character boundary, as answers carry it.
pub fn clip(text: &str) -> &str {
    let mut end = text.len().min(MAX_TEXT_BYTES);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

/// Characters of an id that logs and reports show.
pub const SHORT_ID_CHARS: usize = 64;

/// An id cut to its first [`SHORT_ID_CHARS`] characters, for logs and reports.
pub fn short_id(id: &str) -> &str {
    id.char_indices()
        .nth(SHORT_ID_CHARS)
        .map_or(id, |(end, _)| &id[..end])
}

/// A recommendation whose numbers all say "no answer" (NaN), for a refused candidate.
fn refused(m: &GraspCandidate, status: u8, message: String) -> GripRecommendation {
    let nan = f64::NAN;
    let mut header = m.header.clone();
    header.frame_id = clip(&header.frame_id).to_string();
    GripRecommendation {
        header,
        candidate_id: clip(&m.id).to_string(),
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
        grasp_case: String::new(),
        local_minima: Vec::new(),
        local_minima_power: Vec::new(),
        local_minima_labels: Vec::new(),
        objective: String::new(),
        recommended_label: String::new(),
        candidate_c: GripRecommendation::CANDIDATE_C_OUT_OF_RANGE,
        finger_force: nan,
        finger_force_current: nan,
    }
}

/// The answer to a candidate whose input is bad.
pub fn invalid(m: &GraspCandidate, why: &dyn std::fmt::Display) -> GripRecommendation {
    refused(
        m,
        GripRecommendation::STATUS_INVALID_INPUT,
        format!("invalid input: {why}"),
    )
}

fn no_closure(m: &GraspCandidate, why: &NoForceClosure) -> GripRecommendation {
    let mut out = refused(
        m,
        GripRecommendation::STATUS_NO_FORCE_CLOSURE,
        why.to_string(),
    );
    out.gripping_power_current = f64::INFINITY;
    out.internal_force_current = f64::INFINITY;
    out.finger_force_current = f64::INFINITY;
    out
}

fn recommended(m: &GraspCandidate, r: &Recommendation) -> GripRecommendation {
    let half = 0.5 * r.wrist_rotation;
    GripRecommendation {
        header: m.header.clone(),
        candidate_id: m.id.clone(),
        status: GripRecommendation::STATUS_OK,
        message: String::new(),
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
        gripping_power: r.gripping_power,
        internal_force: r.internal_force,
        contact_forces: r.contact_forces,
        gripping_power_current: r.gripping_power_current,
        internal_force_current: r.internal_force_current,
        grasp_case: r.grasp_case.name().to_string(),
        local_minima: r.local_minima.iter().map(|l| l.gravity_angle).collect(),
        local_minima_power: r.local_minima.iter().map(|l| l.power).collect(),
        local_minima_labels: r
            .local_minima
            .iter()
            .map(|l| l.label.map_or(String::new(), |x| x.name().to_string()))
            .collect(),
        objective: r.objective.name().to_string(),
        recommended_label: r
            .recommended_label
            .map_or(String::new(), |x| x.name().to_string()),
        candidate_c: r.candidate_c as u8,
        finger_force: r.finger_force,
        finger_force_current: r.finger_force_current,
    }
}

/// Solves one candidate message and builds its answer: status 0 with the recommendation, 1 when
/// no orientation holds the grasp, 2 when the input is bad.
pub fn answer(m: &GraspCandidate, settings: &Settings) -> GripRecommendation {
    let mut out = match Candidate::try_from(m) {
        Err(e) => invalid(m, &e),
        Ok(candidate) => match solve_orientation(&candidate, settings) {
            Ok(Verdict::Recommended(r)) => return recommended(m, &r),
            Ok(Verdict::NoForceClosure(why)) => no_closure(m, &why),
            Err(e) => invalid(m, &e),
        },
    };
    // A refused answer still says which objective it was asked under.
    out.objective = settings.objective.name().to_string();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    /// Table 1 (c): a square held at the middle of two opposite sides.
    fn paper_case_c() -> GraspCandidate {
        crate::msg::paper_cases().swap_remove(2)
    }

    #[test]
    fn good_candidate_gets_status_ok_and_a_unit_quaternion() {
        let a = answer(&paper_case_c(), &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        assert_eq!(a.candidate_id, "paper-c");
        let q = &a.rotation;
        assert_abs_diff_eq!(q.z * q.z + q.w * q.w, 1.0, epsilon = 1e-15);
        assert_abs_diff_eq!(2.0 * q.z.atan2(q.w), a.wrist_rotation, epsilon = 1e-12);
        assert_eq!(a.local_minima.len(), a.local_minima_labels.len());
        assert_eq!(a.objective, "norm2");
    }

    #[test]
    fn bad_values_get_status_2_naming_the_field() {
        let mut m = paper_case_c();
        m.mass = f64::NAN;
        let a = answer(&m, &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_INVALID_INPUT);
        assert!(a.message.contains("mass"), "{}", a.message);
        let mut m = paper_case_c();
        m.contact_2.z = f64::INFINITY;
        assert!(answer(&m, &Settings::default())
            .message
            .contains("contact_2.z"));
        let mut m = paper_case_c();
        m.center_of_mass.x = 1e300;
        assert!(answer(&m, &Settings::default())
            .message
            .contains("center_of_mass.x"));
        let mut m = paper_case_c();
        m.id = "x".repeat(1 << 20);
        let a = answer(&m, &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_INVALID_INPUT);
        assert!(a.message.contains("id is 1048576 bytes"), "{}", a.message);
        assert_eq!(a.candidate_id.len(), MAX_TEXT_BYTES);
    }

    #[test]
    fn no_force_closure_gets_status_1_naming_the_cone() {
        let mut m = paper_case_c();
        m.friction_2 = 0.05;
        m.normal_2 = Vector3 {
            x: 1.0,
            y: 0.3,
            z: 0.0,
        };
        let a = answer(&m, &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_NO_FORCE_CLOSURE);
        assert!(
            a.message.contains("cone at contact_2") && a.message.contains("misses contact_1"),
            "{}",
            a.message
        );
        assert!(a.gripping_power_current.is_infinite());
        assert!(a.finger_force_current.is_infinite() && a.finger_force.is_nan());
    }
}
