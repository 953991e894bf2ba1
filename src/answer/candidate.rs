//! One candidate message answered: which solver runs (planar or spatial, nominal or robust), with
//! which tolerances, and what its outcome becomes.
//!
//! A candidate with tolerances (`center_of_mass_tolerance`, `mass_tolerance`) is answered with the
//! worst case over every object they allow ([`planar::robust::solve`]; for a spatial one with a
//! centre-of-mass box [`spatial::robust::solve`], whose answer fixes the tilt of the contact axis,
//! the object swinging to hang in its own plane); with both zero the answer is the nominal one,
//! bit for bit, with `gripping_power_nominal = gripping_power`.

use super::forces::Forces;
use super::reply::{no_closure, recommended, spatial_recommended};
use crate::msg::convert::{invalid, planar_uncertainty, MessageLimits};
use crate::msg::{CompactString, GraspCandidate, GripRecommendation};
use crate::solver::{
    planar::{self, analyse, Candidate, Recommendation, Verdict},
    spatial, InvalidInput, Settings, BEHIND_TANGENT, MAX_COORDINATE,
};
use compact_str::ToCompactString as _;

/// A candidate message answered, with the 3D solution when it is a spatial grasp that holds (the
/// markers of a spatial answer are drawn from it).
#[derive(Debug, Clone)]
pub struct Answered {
    /// The answer as published.
    pub reply: GripRecommendation,
    /// The spatial solver's answer, for a spatial candidate answered with status 0.
    pub spatial: Option<Box<spatial::Recommendation>>,
}

/// Solves one candidate message and builds its answer: status 0 with the recommendation, 1 when
/// no orientation holds the grasp, 2 when the input is bad.
pub(crate) fn answer(m: &GraspCandidate, settings: &Settings) -> GripRecommendation {
    // A planar answer is returned as it is built: through `Answered` it was moved twice more,
    // which a set of 1,000 paid for in copies of the whole message.
    match m.model {
        GraspCandidate::MODEL_PLANAR => planar_reply(m, settings),
        _ => answer_in_full(m, settings).reply,
    }
}

/// [`answer`], with the 3D solution of a spatial grasp.
pub fn answer_in_full(m: &GraspCandidate, settings: &Settings) -> Answered {
    match m.model {
        GraspCandidate::MODEL_PLANAR => answer_planar(m, settings),
        GraspCandidate::MODEL_SPATIAL => answer_spatial(m, settings),
        value => {
            let mut reply = invalid(m, &MessageLimits::Model { value });
            reply.objective = CompactString::const_new(settings.objective.name());
            Answered {
                reply,
                spatial: None,
            }
        }
    }
}

/// Whether a candidate gives no tolerance at all (every field exactly zero, either sign): then
/// it is answered as before tolerances existed.
fn is_exact(m: &GraspCandidate) -> bool {
    let t = &m.center_of_mass_tolerance;
    t.x == 0.0 && t.y == 0.0 && t.z == 0.0 && m.mass_tolerance == 0.0
}

/// The planar answer: the nominal solver's without tolerances, the robust solver's with them
/// (status 1 naming the point of the box that fails, with the nominal answer in the fields, when
/// no allowed orientation holds every object).
fn solve_planar(
    m: &GraspCandidate,
    settings: &Settings,
) -> Result<GripRecommendation, MessageLimits> {
    let candidate = Candidate::try_from(m)?;
    if is_exact(m) {
        // `planar::solve` without its `Box`: the answer is built from the recommendation at
        // once, and one heap block fewer is one of a handful per candidate.
        return match analyse(&candidate, settings) {
            Ok(Ok(analysis)) => analysis
                .recommend(&settings.range)
                .map(|r| recommended(m, &r, &Forces::from(&r)))
                .map_err(MessageLimits::from),
            Ok(Err(why)) => Ok(no_closure(m, &why)),
            Err(e) => Err(e.into()),
        };
    }
    let uncertainty = planar_uncertainty(m)?;
    match planar::robust::solve(&candidate, &uncertainty, settings) {
        Ok(planar::robust::Verdict::Exact(Verdict::Recommended(r))) => {
            Ok(recommended(m, &r, &Forces::from(&*r)))
        }
        Ok(planar::robust::Verdict::Exact(Verdict::NoForceClosure(why))) => Ok(no_closure(m, &why)),
        Ok(planar::robust::Verdict::Recommended(r)) => {
            Ok(recommended(m, &r.to_recommendation(), &Forces::from(&*r)))
        }
        Ok(planar::robust::Verdict::NoCommonOrientation { reason, nominal }) => {
            let mut out = recommended(m, &nominal, &Forces::from(&*nominal));
            out.status = GripRecommendation::STATUS_NO_FORCE_CLOSURE;
            out.message = reason.to_compact_string();
            Ok(out)
        }
        Ok(planar::robust::Verdict::NoForceClosure(why)) => Ok(no_closure(m, &why)),
        Err(e) => Err(e.into()),
    }
}

/// The answer to a candidate read in the planar model.
fn answer_planar(m: &GraspCandidate, settings: &Settings) -> Answered {
    Answered {
        reply: planar_reply(m, settings),
        spatial: None,
    }
}

/// The published answer to a candidate read in the planar model.
fn planar_reply(m: &GraspCandidate, settings: &Settings) -> GripRecommendation {
    let mut reply = solve_planar(m, settings).unwrap_or_else(|why| invalid(m, &why));
    // A refused answer still says which objective it was asked under.
    if reply.objective.is_empty() {
        reply.objective = CompactString::const_new(settings.objective.name());
    }
    note_behind_tangent(&mut reply, m);
    reply
}

/// The start of the note in `message` for a centre of mass behind the surface tangent at a
/// contact; the contacts follow (`contact_1`, `contact_2`, or both joined by " and ").
pub(crate) const BEHIND_TANGENT_NOTE: &str = "center_of_mass lies behind the surface tangent at ";

/// Adds [`BEHIND_TANGENT_NOTE`] to the `message` of an answered candidate (status not 2) whose
/// centre of mass lies behind the surface tangent at a contact: an object that is not convex
/// there. The solver answers it as any other (the statics never needed convexity,
/// `docs/theory.md#a-centre-of-mass-behind-a-tangent`); the note says that the input is unusual,
/// in case a mesh's normal or the centre of mass is wrong. The planar model reads the x-y parts.
fn note_behind_tangent(reply: &mut GripRecommendation, m: &GraspCandidate) {
    if reply.status == GripRecommendation::STATUS_INVALID_INPUT {
        return;
    }
    let planar = m.model == GraspCandidate::MODEL_PLANAR;
    let v = |x: f64, y: f64, z: f64| nalgebra::Vector3::new(x, y, if planar { 0.0 } else { z });
    let com = v(m.center_of_mass.x, m.center_of_mass.y, m.center_of_mass.z);
    let behind: Vec<&str> = [
        ("contact_1", &m.contact_1, &m.normal_1),
        ("contact_2", &m.contact_2, &m.normal_2),
    ]
    .into_iter()
    .filter(|(_, p, n)| {
        // Each vector divided by its largest component first: no square under- or overflows.
        let unit = |w: nalgebra::Vector3<f64>| {
            let big = w.amax();
            (big > 0.0).then(|| (w / big).normalize())
        };
        match (unit(v(n.x, n.y, n.z)), unit(com - v(p.x, p.y, p.z))) {
            (Some(n), Some(to)) => n.dot(&to) < -BEHIND_TANGENT,
            _ => false,
        }
    })
    .map(|(name, _, _)| name)
    .collect();
    if behind.is_empty() {
        return;
    }
    let note = format!(
        "{BEHIND_TANGENT_NOTE}{} (the object is not convex there)",
        behind.join(" and ")
    );
    reply.message = if reply.message.is_empty() {
        note.into()
    } else {
        format!("{}; {note}", reply.message).into()
    };
}

/// The answer to a candidate read in the spatial model. A mass tolerance alone scales every
/// force of the nominal answer by `(m + Δm) / m`: at a fixed pose every force is proportional to
/// the mass (`crates/solver/src/planar/robust/mod.rs`, section 1), so the largest mass is the
/// worst and the pose does not change. A centre-of-mass box is answered by [`spatial::robust::solve`]: every object
/// swings about the contact axis to hang in its own plane, and the answer fixes the tilt of the
/// axis whose worst case is least ([`spatial_robust_recommended`]).
fn answer_spatial(m: &GraspCandidate, settings: &Settings) -> Answered {
    let mut out = answer_spatial_unnoted(m, settings);
    note_behind_tangent(&mut out.reply, m);
    out
}

/// [`answer_spatial`] without the note on a centre of mass behind a tangent.
fn answer_spatial_unnoted(m: &GraspCandidate, settings: &Settings) -> Answered {
    let mut out = match spatial_tolerance(m)
        .map_err(|e| e.to_string())
        .and_then(|tolerance| {
            spatial::Candidate::try_from(m)
                .map(|c| (c, tolerance))
                .map_err(|e| e.to_string())
        }) {
        Err(e) => invalid(m, &e),
        Ok((candidate, SpatialTolerance::Box(u))) => {
            match spatial::robust::solve(&candidate, &u, settings) {
                Ok(spatial::robust::Verdict::Recommended(r)) => {
                    let (reply, nominal_hang) = spatial_robust_recommended(m, &r);
                    return Answered {
                        reply,
                        spatial: Some(Box::new(nominal_hang)),
                    };
                }
                Ok(spatial::robust::Verdict::NoCommonOrientation { reason, nominal }) => {
                    let mut reply =
                        spatial_recommended(m, &nominal, &Forces::from(&nominal.planar));
                    reply.status = GripRecommendation::STATUS_NO_FORCE_CLOSURE;
                    reply.message = reason.to_compact_string();
                    reply
                }
                Ok(spatial::robust::Verdict::NoForceClosure(why)) => no_closure(m, &why),
                // Not reached: a box of zero size is not a `Box`.
                Ok(spatial::robust::Verdict::Exact(spatial::Verdict::Recommended(r))) => {
                    return Answered {
                        reply: spatial_recommended(m, &r, &Forces::from(&r.planar)),
                        spatial: Some(r),
                    };
                }
                Ok(spatial::robust::Verdict::Exact(spatial::Verdict::NoForceClosure(why))) => {
                    no_closure(m, &why)
                }
                Err(InvalidInput::Norm1SpatialTolerance) => invalid(m, &NORM1_WITH_BOX),
                Err(e) => invalid(m, &e),
            }
        }
        Ok((candidate, tolerance)) => match spatial::solve(&candidate, settings) {
            Ok(spatial::Verdict::Recommended(r)) => {
                let forces = Forces::from(&r.planar);
                let reply = match tolerance {
                    SpatialTolerance::Mass(k) => {
                        let mut reply = spatial_recommended(m, &r, &forces.scaled(k));
                        for p in &mut reply.local_minima_power {
                            *p *= k;
                        }
                        reply
                    }
                    _ => spatial_recommended(m, &r, &forces),
                };
                return Answered {
                    reply,
                    spatial: Some(r),
                };
            }
            Ok(spatial::Verdict::NoForceClosure(why)) => no_closure(m, &why),
            Err(e) => invalid(m, &e),
        },
    };
    out.objective = CompactString::const_new(settings.objective.name());
    Answered {
        reply: out,
        spatial: None,
    }
}

/// The answer to a spatial candidate with a centre-of-mass box that every object in it can be
/// held at: the worst cases (objective, squeeze, finger force, at the recommended tilt and after
/// the swing at the current pose), the nominal object's objective and contact forces at rest at
/// that tilt, and the pose as the nominal object's hang (`gravity_direction`, the rotation to
/// it); `gravity_angle` is the tilt `θ*` of the contact axis, in the nominal object's plane.
/// Also the nominal solution with that hang, from which the markers are drawn.
fn spatial_robust_recommended(
    m: &GraspCandidate,
    r: &spatial::robust::Recommendation,
) -> (GripRecommendation, spatial::Recommendation) {
    let mut hang = r.nominal.clone();
    hang.planar = Recommendation {
        objective: r.objective,
        gravity_angle: r.gravity_angle,
        gripping_power: r.gripping_power,
        internal_force: r.internal_force,
        contact_forces: r.contact_forces,
        gripping_power_current: r.gripping_power_current,
        internal_force_current: r.internal_force_current,
        current_gravity_angle: r.current_gravity_angle,
        local_minima: r.local_minima.clone(),
        recommended_label: None,
        finger_force: r.finger_force,
        finger_force_current: r.finger_force_current,
        ..r.nominal.planar.clone()
    };
    hang.gravity_direction = r.gravity_direction;
    hang.rotation_axis = r.rotation_axis;
    hang.rotation_angle = r.rotation_angle;
    hang.force_vectors = r.force_vectors;
    (spatial_recommended(m, &hang, &Forces::from(r)), hang)
}

/// The refusal of a spatial candidate with a centre-of-mass box under objective norm1, naming
/// where the box may come from and where the limit is documented: the solver's own words
/// (`InvalidInput::Norm1SpatialTolerance`) do not say that the node's parameter gives a box to
/// every candidate without one.
const NORM1_WITH_BOX: &str = "objective norm1 with a center_of_mass_tolerance box (the \
    candidate's own, or the parameter center_of_mass_tolerance where the candidate gives none) \
    is not supported for spatial candidates (docs/uncertainty.md#spatial-candidates); use \
    objective norm2 or internal_force";

/// What a spatial candidate's tolerances ask for.
enum SpatialTolerance {
    /// None: the nominal answer.
    Exact,
    /// A mass tolerance alone: the nominal answer's forces times `(m + Δm) / m`.
    Mass(f64),
    /// A centre-of-mass box (and perhaps a mass tolerance): the spatial robust solver.
    Box(spatial::robust::Uncertainty),
}

/// A spatial candidate's tolerances, or an error naming the field at fault (the robust solver
/// checks a box's mass tolerance itself).
fn spatial_tolerance(m: &GraspCandidate) -> Result<SpatialTolerance, MessageLimits> {
    let t = &m.center_of_mass_tolerance;
    for (field, v) in [
        ("center_of_mass_tolerance.x", t.x),
        ("center_of_mass_tolerance.y", t.y),
        ("center_of_mass_tolerance.z", t.z),
        ("mass_tolerance", m.mass_tolerance),
    ] {
        if !v.is_finite() {
            return Err(InvalidInput::NotFinite { field }.into());
        }
        if field != "mass_tolerance" && !(0.0..MAX_COORDINATE).contains(&v) {
            return Err(InvalidInput::Tolerance {
                field,
                value: v,
                limit: MAX_COORDINATE,
                unit: " m",
            }
            .into());
        }
    }
    if t.x != 0.0 || t.y != 0.0 || t.z != 0.0 {
        return Ok(SpatialTolerance::Box(spatial::robust::Uncertainty {
            center_of_mass_tolerance: nalgebra::Vector3::new(t.x, t.y, t.z),
            mass_tolerance: m.mass_tolerance,
        }));
    }
    let dm = m.mass_tolerance;
    if dm == 0.0 {
        return Ok(SpatialTolerance::Exact);
    }
    if !(m.mass.is_finite() && m.mass > 0.0) {
        // The solver names the mass.
        return Ok(SpatialTolerance::Exact);
    }
    if !(0.0..m.mass).contains(&dm) {
        return Err(InvalidInput::Tolerance {
            field: "mass_tolerance",
            value: dm,
            limit: m.mass,
            unit: " kg",
        }
        .into());
    }
    Ok(SpatialTolerance::Mass((m.mass + dm) / m.mass))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Vector3, MAX_TEXT_BYTES};
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

    /// Paper case (c) with its centre of mass moved behind the tangent at contact 1 (past that
    /// side of the square, off the contact line): an object that is not convex there.
    fn behind_contact_1() -> GraspCandidate {
        let mut m = paper_case_c();
        let (p1, p2) = (&m.contact_1, &m.contact_2);
        let d = (p1.x - p2.x).hypot(p1.y - p2.y);
        let len = m.normal_1.x.hypot(m.normal_1.y);
        let (nx, ny) = (m.normal_1.x / len, m.normal_1.y / len);
        m.center_of_mass.x = p1.x - 0.3 * d * nx - 0.2 * d * ny;
        m.center_of_mass.y = p1.y - 0.3 * d * ny + 0.2 * d * nx;
        m
    }

    /// Objects need not be convex (`docs/theory.md#a-centre-of-mass-behind-a-tangent`): behind
    /// the tangent at contact 1 is answered as any other (status 0), with the note naming the
    /// contact; with both tolerances too (the robust solver); the case itself carries no note.
    #[test]
    fn centre_of_mass_behind_a_tangent_is_answered_with_a_note() {
        let plain = answer(&paper_case_c(), &Settings::default());
        assert!(plain.message.is_empty(), "{}", plain.message);
        let m = behind_contact_1();
        let a = answer(&m, &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        assert!(a.gripping_power.is_finite());
        assert_eq!(
            a.message,
            format!("{BEHIND_TANGENT_NOTE}contact_1 (the object is not convex there)")
        );
        let mut robust = m.clone();
        robust.center_of_mass_tolerance = Vector3 {
            x: 0.01,
            y: 0.01,
            z: 0.0,
        };
        robust.mass_tolerance = 0.1 * robust.mass;
        let r = answer(&robust, &Settings::default());
        assert_ne!(
            r.status,
            GripRecommendation::STATUS_INVALID_INPUT,
            "{}",
            r.message
        );
        assert!(r.message.contains(BEHIND_TANGENT_NOTE), "{}", r.message);
        let mut spatial = m;
        spatial.model = GraspCandidate::MODEL_SPATIAL;
        let s = answer(&spatial, &Settings::default());
        assert_eq!(s.status, GripRecommendation::STATUS_OK, "{}", s.message);
        assert!(s.message.contains(BEHIND_TANGENT_NOTE), "{}", s.message);
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
        m.id = "x".repeat(1 << 20).into();
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

#[cfg(test)]
mod spatial_tests {
    use super::*;
    use crate::msg::Header;
    use crate::msg::{Point, Vector3};
    use crate::solver::planar::robust::Uncertainty;
    use nalgebra::Vector2;
    use std::f64::consts::PI;

    fn p(x: f64, y: f64, z: f64) -> Point {
        Point { x, y, z }
    }

    fn v(x: f64, y: f64, z: f64) -> Vector3 {
        Vector3 { x, y, z }
    }

    /// The paper's case (c) square stood up in the y-z plane, gravity along -z.
    fn upright_square() -> GraspCandidate {
        GraspCandidate {
            header: Header {
                frame_id: "tool0".into(),
                ..Header::default()
            },
            id: "upright".into(),
            contact_1: p(0.0, 1.0, 1.0),
            contact_2: p(0.0, -1.0, 1.0),
            normal_1: v(0.0, -1.0, 0.0),
            normal_2: v(0.0, 1.0, 0.0),
            friction_1: 3f64.sqrt(),
            friction_2: 1.0 / 3f64.sqrt(),
            center_of_mass: p(0.0, 0.0, 0.0),
            mass: 1.0,
            gravity: v(0.0, 0.0, -1.0),
            model: GraspCandidate::MODEL_SPATIAL,
            center_of_mass_tolerance: v(0.0, 0.0, 0.0),
            mass_tolerance: 0.0,
        }
    }

    #[test]
    fn spatial_answer_carries_the_3d_rotation_and_the_planar_answer_in_the_plane() {
        let m = upright_square();
        let settings = Settings::default();
        let Answered { reply: a, spatial } = answer_in_full(&m, &settings);
        let r = spatial.expect("a spatial answer with status 0");
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        assert_eq!(
            (a.candidate_id.as_str(), a.header.frame_id.as_str()),
            ("upright", "tool0")
        );
        assert!(a.message.is_empty(), "{}", a.message);
        assert!((a.wrist_rotation - PI / 12.0).abs() < 1e-12);
        assert_eq!(a.wrist_rotation, r.rotation_angle);
        // The quaternion turns about the rotation axis (±x, the normal of the grasp plane) by the
        // wrist rotation.
        let q = &a.rotation;
        assert!((q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0).abs() < 1e-15);
        assert!((2.0 * q.x.abs().atan2(q.w) - a.wrist_rotation).abs() < 1e-12);
        assert!(q.y == 0.0 && q.z == 0.0);
        assert_eq!(q.x.signum(), r.rotation_axis.x.signum());
        let k = &a.rotation_axis;
        assert_eq!((k.x, k.y, k.z), (r.rotation_axis.x, 0.0, 0.0));
        assert_eq!(k.x.abs(), 1.0);
        // Gravity after the rotation: in the y-z plane, a unit vector, π/12 from -z.
        let g = &a.gravity_direction;
        assert!(g.x.abs() < 1e-15 && (g.y.hypot(g.z) - 1.0).abs() < 1e-15);
        assert!((-g.z - (PI / 12.0).cos()).abs() < 1e-12);
        // The rest is the planar answer in Π.
        assert_eq!(a.gravity_angle, r.planar.gravity_angle);
        assert_eq!(a.gripping_power, r.planar.gripping_power);
        assert_eq!(a.contact_forces, r.planar.contact_forces);
        assert_eq!(a.local_minima.len(), r.planar.local_minima.len());
        assert_eq!(a.recommended_label, "C");
        assert!((a.gripping_power - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_planar_grasp_given_as_spatial_answers_as_the_planar_model() {
        let settings = Settings::default();
        for m in crate::msg::paper_cases() {
            let planar = answer(&m, &settings);
            let spatial = answer(
                &GraspCandidate {
                    model: GraspCandidate::MODEL_SPATIAL,
                    ..m.clone()
                },
                &settings,
            );
            assert_eq!(
                (
                    planar.rotation_axis.x,
                    planar.rotation_axis.y,
                    planar.rotation_axis.z
                ),
                (0.0, 0.0, 1.0)
            );
            let k = &spatial.rotation_axis;
            assert_eq!((k.x, k.y, k.z.abs()), (0.0, 0.0, 1.0), "{}", m.id);
            assert_eq!(spatial.status, planar.status, "{}", m.id);
            assert!(spatial.message.is_empty(), "{}: {}", m.id, spatial.message);
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(1.0);
            assert!(
                close(spatial.wrist_rotation, planar.wrist_rotation.abs()),
                "{}",
                m.id
            );
            for (a, b) in [
                (spatial.rotation.x, planar.rotation.x),
                (spatial.rotation.y, planar.rotation.y),
                (spatial.rotation.z, planar.rotation.z),
                (spatial.rotation.w, planar.rotation.w),
                (spatial.gravity_direction.x, planar.gravity_direction.x),
                (spatial.gravity_direction.y, planar.gravity_direction.y),
                (spatial.gravity_direction.z, planar.gravity_direction.z),
                (spatial.gravity_angle, planar.gravity_angle),
                (spatial.gripping_power, planar.gripping_power),
                (spatial.internal_force, planar.internal_force),
                (
                    spatial.gripping_power_current,
                    planar.gripping_power_current,
                ),
                (
                    spatial.internal_force_current,
                    planar.internal_force_current,
                ),
            ] {
                assert!(close(a, b), "{}: {a} against planar {b}", m.id);
            }
            for (a, b) in spatial.contact_forces.iter().zip(&planar.contact_forces) {
                assert!(close(*a, *b), "{}", m.id);
            }
            assert_eq!(spatial.local_minima_labels, planar.local_minima_labels);
            assert_eq!(
                (
                    &spatial.grasp_case,
                    &spatial.recommended_label,
                    spatial.candidate_c
                ),
                (
                    &planar.grasp_case,
                    &planar.recommended_label,
                    planar.candidate_c
                )
            );
        }
    }

    #[test]
    fn an_object_that_would_swing_has_infinite_current_fields_and_says_so() {
        let mut m = upright_square();
        m.gravity = v(0.3, 0.0, -1.0); // out of the y-z plane
        let a = answer_in_full(&m, &Settings::default()).reply;
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        assert!(a.gripping_power_current == f64::INFINITY);
        assert!(a.internal_force_current == f64::INFINITY);
        assert!(a.gripping_power.is_finite());
        assert!(
            a.message.contains("swings about the contact axis"),
            "{}",
            a.message
        );
        assert!(
            a.message.contains("0.291457 rad out of the grasp plane"),
            "{}",
            a.message
        );
    }

    #[test]
    fn a_centre_of_mass_on_or_near_the_axis_is_flagged_sensitive() {
        let mut m = upright_square();
        m.center_of_mass = p(0.0, 0.2, 1.0); // on the contact axis
        let a = answer_in_full(&m, &Settings::default()).reply;
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        assert!(a.message.contains("sensitive") && a.message.contains("on the contact axis"));
        m.center_of_mass = p(0.0, 0.2, 0.99); // 0.5% of the contact distance off it
        let a = answer_in_full(&m, &Settings::default()).reply;
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        assert!(a.message.contains("sensitive") && a.message.contains("within 1%"));
        // Both notes at once, joined.
        m.gravity = v(1.0, 0.0, -1.0);
        let a = answer_in_full(&m, &Settings::default()).reply;
        assert!(
            a.message.contains("swings") && a.message.contains("; sensitive"),
            "{}",
            a.message
        );
    }

    #[test]
    fn refusals_name_the_field_and_no_closure_names_the_contact() {
        let settings = Settings::default();
        let refused = |f: &dyn Fn(&mut GraspCandidate)| {
            let mut m = upright_square();
            f(&mut m);
            let a = answer_in_full(&m, &settings);
            assert!(a.spatial.is_none());
            a.reply
        };
        type Change<'a> = &'a dyn Fn(&mut GraspCandidate);
        let cases: [(Change, &str); 9] = [
            (
                &|m| m.contact_1.z = f64::NAN,
                "contact_1.z is not a finite number",
            ),
            (
                &|m| m.center_of_mass.z = 2e6,
                "center_of_mass.z is out of range",
            ),
            (
                &|m| m.normal_2 = v(0.0, 0.0, 0.0),
                "normal_2 is the zero vector",
            ),
            (
                &|m| m.gravity = v(0.0, 0.0, 0.0),
                "gravity is the zero vector",
            ),
            (
                &|m| m.normal_1 = v(1.0, 0.0, 0.0),
                "normal_1 is perpendicular to the grasp plane",
            ),
            (
                &|m| m.center_of_mass = p(0.0, 1.0, 1.0),
                "center_of_mass coincides with contact_1",
            ),
            (&|m| m.id = "x".repeat(2000).into(), "id is 2000 bytes long"),
            (&|m| m.model = 2, "model is 2: it must be 0 (MODEL_PLANAR"),
            (&|m| m.model = 255, "model is 255"),
        ];
        for (f, words) in cases {
            let a = refused(f);
            assert_eq!(
                a.status,
                GripRecommendation::STATUS_INVALID_INPUT,
                "{words}"
            );
            assert!(a.message.contains(words), "{} lacks {words:?}", a.message);
            assert!(a.gravity_angle.is_nan() && a.wrist_rotation.is_nan());
            assert!(a.rotation_axis.x.is_nan() && a.rotation_axis.z.is_nan());
            assert_eq!(a.objective, "norm2");
        }
        // Normal 1 tilted 0.6 rad out of the y-z plane, friction angle 0.5 rad.
        let a = refused(&|m| {
            m.normal_1 = v(0.6f64.sin(), -(0.6f64.cos()), 0.0);
            m.friction_1 = 0.5f64.tan();
        });
        assert_eq!(a.status, GripRecommendation::STATUS_NO_FORCE_CLOSURE);
        assert!(
            a.message
                .contains("normal at contact_1 is tilted out of the grasp plane by 0.6000 rad"),
            "{}",
            a.message
        );
        assert!(a.gripping_power_current.is_infinite() && a.gripping_power.is_nan());
    }

    fn paper_case_c() -> GraspCandidate {
        crate::msg::paper_cases().swap_remove(2)
    }

    fn with_tolerances(mut m: GraspCandidate, t: [f64; 3], dm: f64) -> GraspCandidate {
        let [x, y, z] = t;
        m.center_of_mass_tolerance = Vector3 { x, y, z };
        m.mass_tolerance = dm;
        m
    }

    /// Zero tolerances (either sign) are today's answer, bit for bit, with the nominal power equal
    /// to the reported one; a z tolerance alone does not matter to a planar candidate.
    #[test]
    fn zero_tolerances_are_todays_answer() {
        for c in crate::msg::paper_cases() {
            let a = answer(&c, &Settings::default());
            assert_eq!(
                a.gripping_power_nominal.to_bits(),
                a.gripping_power.to_bits()
            );
            let signed = with_tolerances(c.clone(), [-0.0, 0.0, -0.0], -0.0);
            let b = answer(&signed, &Settings::default());
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
            let z_only = with_tolerances(c.clone(), [0.0, 0.0, 0.5], 0.0);
            assert_eq!(
                format!("{a:?}"),
                format!("{:?}", answer(&z_only, &Settings::default()))
            );
        }
    }

    /// With tolerances the fields are the robust solver's: worst cases, the nominal power and
    /// contact forces of the nominal object, at the robust pose.
    #[test]
    fn tolerances_give_the_robust_solvers_worst_case() {
        let m = with_tolerances(paper_case_c(), [0.002, 0.001, 0.0], 0.02);
        let a = answer(&m, &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_OK, "{}", a.message);
        let candidate = Candidate::try_from(&m).expect("valid");
        let u = Uncertainty {
            center_of_mass_tolerance: Vector2::new(0.002, 0.001),
            mass_tolerance: 0.02,
        };
        let Ok(planar::robust::Verdict::Recommended(r)) =
            planar::robust::solve(&candidate, &u, &Settings::default())
        else {
            panic!("every object in the box can be held");
        };
        assert_eq!(a.gripping_power, r.gripping_power);
        assert_eq!(a.internal_force, r.internal_force);
        assert_eq!(a.finger_force, r.finger_force);
        assert_eq!(a.gripping_power_current, r.gripping_power_current);
        assert_eq!(a.finger_force_current, r.finger_force_current);
        assert_eq!(a.wrist_rotation, r.wrist_rotation);
        assert_eq!(a.contact_forces, r.contact_forces);
        assert_eq!(a.gripping_power_nominal, r.gripping_power_nominal);
        assert!(a.gripping_power > a.gripping_power_nominal);
        let exact = answer(&paper_case_c(), &Settings::default());
        assert!(a.gripping_power > exact.gripping_power);
    }

    /// Bad tolerances get status 2 naming the field.
    #[test]
    fn bad_tolerances_get_status_2_naming_the_field() {
        for (t, dm, field) in [
            ([-0.01, 0.0, 0.0], 0.0, "center_of_mass_tolerance.x"),
            ([0.0, f64::NAN, 0.0], 0.0, "center_of_mass_tolerance.y"),
            ([0.0, 0.0, f64::INFINITY], 0.0, "center_of_mass_tolerance.z"),
            ([1e7, 0.0, 0.0], 0.0, "center_of_mass_tolerance.x"),
            ([0.0, 0.0, 0.0], -0.1, "mass_tolerance"),
            ([0.0, 0.0, 0.0], 1.0, "mass_tolerance"),
            ([0.01, 0.0, 0.0], f64::NAN, "mass_tolerance"),
        ] {
            for model in [GraspCandidate::MODEL_PLANAR, GraspCandidate::MODEL_SPATIAL] {
                let mut m = with_tolerances(paper_case_c(), t, dm);
                m.model = model;
                let a = answer(&m, &Settings::default());
                assert_eq!(
                    a.status,
                    GripRecommendation::STATUS_INVALID_INPUT,
                    "{t:?} {dm}"
                );
                assert!(a.message.contains(field), "{field}: {}", a.message);
                assert_eq!(a.objective, "norm2");
            }
        }
    }

    /// A box reaching across the contact line: status 1 naming the point, the nominal answer in
    /// the fields.
    #[test]
    fn no_common_orientation_is_status_1_with_the_nominal_answer() {
        let m = with_tolerances(paper_case_c(), [0.0, 2.0, 0.0], 0.0);
        let a = answer(&m, &Settings::default());
        assert_eq!(a.status, GripRecommendation::STATUS_NO_FORCE_CLOSURE);
        assert!(
            a.message.contains("either side of the line"),
            "{}",
            a.message
        );
        let exact = answer(&paper_case_c(), &Settings::default());
        assert_eq!(a.gripping_power, exact.gripping_power);
        assert_eq!(a.wrist_rotation, exact.wrist_rotation);
        assert_eq!(a.gripping_power_nominal, exact.gripping_power);
    }

    /// Objective norm1 with a box on a spatial candidate is refused naming where the box comes
    /// from and the page that says so; a planar candidate with the same box is answered.
    #[test]
    fn norm1_with_a_spatial_box_is_refused_naming_the_parameter_and_the_docs() {
        let norm1 = Settings {
            objective: crate::solver::Objective::Norm1,
            ..Settings::default()
        };
        let boxed = with_tolerances(upright_square(), [0.01, 0.02, 0.0], 0.0);
        let a = answer(&boxed, &norm1);
        assert_eq!(a.status, GripRecommendation::STATUS_INVALID_INPUT);
        assert_eq!(a.message, format!("invalid input: {NORM1_WITH_BOX}"));
        assert!(
            a.message.contains("parameter center_of_mass_tolerance")
                && a.message.contains("docs/uncertainty.md#spatial-candidates"),
            "{}",
            a.message
        );
        let docs = include_str!("../../docs/uncertainty.md");
        assert!(docs.contains("## Spatial candidates") && docs.contains("objective `norm1`"));
        let readme = include_str!("../../README.md");
        assert!(readme.contains("norm1"), "the README names the limit");
        let planar = crate::msg::paper_cases().swap_remove(2);
        let planar = with_tolerances(planar, [0.01, 0.02, 0.0], 0.0);
        let a = answer(&planar, &norm1);
        assert_ne!(
            a.status,
            GripRecommendation::STATUS_INVALID_INPUT,
            "{}",
            a.message
        );
    }

    /// Spatial candidates: a mass tolerance scales every force but the nominal object's by
    /// `(m + Δm) / m`; a centre-of-mass box is the spatial robust solver's answer.
    #[test]
    fn spatial_mass_tolerance_scales_and_box_is_the_robust_answer() {
        let m = upright_square();
        let exact = answer(&m, &Settings::default());
        let heavy = answer(
            &with_tolerances(m.clone(), [0.0; 3], 0.25),
            &Settings::default(),
        );
        assert_eq!(
            heavy.status,
            GripRecommendation::STATUS_OK,
            "{}",
            heavy.message
        );
        let k = 1.25;
        assert_eq!(heavy.gripping_power, exact.gripping_power * k);
        assert_eq!(heavy.internal_force, exact.internal_force * k);
        assert_eq!(heavy.finger_force, exact.finger_force * k);
        assert_eq!(heavy.gripping_power_nominal, exact.gripping_power);
        assert_eq!(heavy.contact_forces, exact.contact_forces);
        assert_eq!(heavy.wrist_rotation, exact.wrist_rotation);
        let boxed_in = with_tolerances(m, [0.01, 0.02, 0.0], 0.1);
        let boxed = answer(&boxed_in, &Settings::default());
        assert_eq!(
            boxed.status,
            GripRecommendation::STATUS_OK,
            "{}",
            boxed.message
        );
        let candidate = spatial::Candidate::try_from(&boxed_in).expect("a valid candidate");
        let u = spatial::robust::Uncertainty {
            center_of_mass_tolerance: nalgebra::Vector3::new(0.01, 0.02, 0.0),
            mass_tolerance: 0.1,
        };
        let Ok(spatial::robust::Verdict::Recommended(r)) =
            spatial::robust::solve(&candidate, &u, &Settings::default())
        else {
            panic!("the box can be held");
        };
        assert_eq!(boxed.gravity_angle, r.gravity_angle);
        assert_eq!(boxed.gripping_power, r.gripping_power);
        assert_eq!(boxed.internal_force, r.internal_force);
        assert_eq!(boxed.finger_force, r.finger_force);
        assert_eq!(boxed.gripping_power_current, r.gripping_power_current);
        assert_eq!(boxed.finger_force_current, r.finger_force_current);
        assert_eq!(boxed.gripping_power_nominal, r.gripping_power_nominal);
        assert_eq!(boxed.contact_forces, r.contact_forces);
        assert_eq!(boxed.wrist_rotation, r.rotation_angle);
        let g = &boxed.gravity_direction;
        assert_eq!(
            [g.x, g.y, g.z],
            [
                r.gravity_direction.x,
                r.gravity_direction.y,
                r.gravity_direction.z
            ]
        );
        assert!(boxed.gripping_power > boxed.gripping_power_nominal);
        // The tilt is the nominal answer's gravity angle in the same frame: a tiny box moves it
        // (and the hang) only a little.
        let tiny = answer(
            &with_tolerances(upright_square(), [1e-9, 1e-9, 1e-9], 0.0),
            &Settings::default(),
        );
        assert_eq!(
            tiny.status,
            GripRecommendation::STATUS_OK,
            "{}",
            tiny.message
        );
        assert!((tiny.gravity_angle - exact.gravity_angle).abs() < 1e-6);
        assert!((tiny.wrist_rotation - exact.wrist_rotation).abs() < 1e-6);
        let (a, b) = (&tiny.gravity_direction, &exact.gravity_direction);
        assert!((a.x - b.x).abs() + (a.y - b.y).abs() + (a.z - b.z).abs() < 1e-6);
        assert!((tiny.gripping_power - exact.gripping_power).abs() < 1e-6 * exact.gripping_power);
        for (t, e) in tiny.contact_forces.iter().zip(&exact.contact_forces) {
            assert!((t - e).abs() < 1e-6 * exact.gripping_power, "{t} vs {e}");
        }
        assert!((tiny.finger_force - exact.finger_force).abs() < 1e-6 * exact.gripping_power);
        assert!(
            (tiny.gripping_power_current - exact.gripping_power_current).abs()
                < 1e-6 * exact.gripping_power
        );
    }

    /// A spatial box reaching past both contacts along the axis (the normals lean down, so the
    /// object is wider below them): the objects beyond contact 1 need the axis tilted one way,
    /// those beyond contact 2 the other; status 1 names them, with the nominal answer.
    #[test]
    fn spatial_box_without_a_common_tilt_is_status_1_with_the_nominal_answer() {
        let m = GraspCandidate {
            normal_1: v(0.0, -1.0, -0.3),
            normal_2: v(0.0, 1.0, -0.3),
            ..upright_square()
        };
        let exact = answer(&m, &Settings::default());
        assert_eq!(
            exact.status,
            GripRecommendation::STATUS_OK,
            "{}",
            exact.message
        );
        let wide = answer(
            &with_tolerances(m, [0.0, 1.2, 0.0], 0.0),
            &Settings::default(),
        );
        assert_eq!(wide.status, GripRecommendation::STATUS_NO_FORCE_CLOSURE);
        assert!(
            wide.message
                .contains("no tilt of the contact axis suits every object"),
            "{}",
            wide.message
        );
        assert_eq!(wide.gripping_power, exact.gripping_power);
        assert_eq!(wide.wrist_rotation, exact.wrist_rotation);
    }
}
