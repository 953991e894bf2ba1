//! Replaying recorded pose candidates and pose sets: each is answered again from the recorded
//! pose and object (the contacts, normals and centre of mass cast again, then the spatial
//! candidate they make solved again, `crate::answer::PoseAnswerer`) and compared with its
//! recorded answer: the recommendation exactly as a candidate's ([`compare_one`]), the geometry
//! within [`TOLERANCE`], and a set's ranking and fields as a candidate set's
//! ([`super::sets`]).
//!
//! The closing axis is the recorded `closing_axis` in force when the pose was received. A mesh
//! named by resource is read again at replay time (`package://` through this process's
//! `AMENT_PREFIX_PATH`): one that cannot be read where the recording answered its pose is an
//! error ([`ReplayError::Mesh`]), not a difference.

use super::compare::{compare_one, number_gap, pair, Summary, TOLERANCE};
use super::plan::{Plan, ReplayError};
use super::sets::{compare_set, rules_like};
use crate::answer::{cut_like, uncast};
use crate::kind::{Kind, PoseSets, Poses};
use crate::msg::{
    short_id, GraspObject, GripRecommendation, GripRecommendationSet, Point, PoseRecommendation,
    PoseRecommendationSet, PoseStamped, Vector3,
};
use crate::record::bag::{keep_example, Bag, Recorded};
use crate::record::channels::RecordedFields;
use grasp_orient_geometry::MeshCache;

/// The new answers of a replay's pose candidates and pose sets, each with its candidate's (or
/// set's) times, in the recording's order; empty unless asked for.
#[derive(Debug, Default)]
pub(crate) struct PoseAnswers {
    /// One per recorded pose candidate.
    pub(crate) recommendations: Vec<Recorded<PoseRecommendation>>,
    /// One per recorded pose set.
    pub(crate) sets: Vec<Recorded<PoseRecommendationSet>>,
}

/// Replays every pose candidate and pose set of `bag` with the meshes of `meshes`, keeping the
/// new answers when `keep`.
pub(super) fn replay_poses(
    bag: &Bag,
    plan: &Plan,
    keep: bool,
) -> Result<(Summary, PoseAnswers), ReplayError> {
    let meshes = plan.meshes();
    let mut summary = Summary::default();
    let mut kept = PoseAnswers::default();
    let (pairs, unmatched) = pair(&bag.streams.poses);
    summary.unmatched_recommendations += unmatched;
    for (c, p) in bag.streams.poses.requests.iter().zip(pairs) {
        let theirs = p.map(|i| &bag.streams.poses.answers[i].message);
        let answered = theirs.is_some_and(|t| answered(&t.recommendation));
        check_mesh(&c.message.object, answered, meshes)?;
        let ours = plan.answering_at(c.log_time).answer::<Poses>(&c.message);
        summary.candidates += 1;
        summary.pose_candidates += 1;
        if let Some(theirs) = theirs {
            let label = || format!("pose candidate {:?}", short_id(&c.message.id));
            let a = (&ours.recommendation, &theirs.recommendation);
            let differ = compare_one(label, a.0, a.1, &bag.fields, &mut summary);
            if !differ && compare_geometry(label, &ours, theirs, &bag.fields, &mut summary) {
                summary.differing += 1;
            }
        }
        if keep {
            kept.recommendations.push(Recorded {
                message: ours,
                log_time: c.log_time,
                publish_time: c.publish_time,
            });
        }
    }
    kept.sets = replay_pose_sets(bag, plan, &mut summary, keep)?;
    Ok((summary, kept))
}

/// Replays every pose set of `bag` into `summary`, returning the new answers when `keep`.
fn replay_pose_sets(
    bag: &Bag,
    plan: &Plan,
    summary: &mut Summary,
    keep: bool,
) -> Result<Vec<Recorded<PoseRecommendationSet>>, ReplayError> {
    let meshes = plan.meshes();
    let mut kept = Vec::new();
    let (pairs, unmatched) = pair(&bag.streams.pose_sets);
    summary.unmatched_set_answers += unmatched;
    for (set, p) in bag.streams.pose_sets.requests.iter().zip(pairs) {
        let theirs = p.map(|i| &bag.streams.pose_sets.answers[i].message);
        let answered = theirs.is_some_and(|t| {
            t.recommendations
                .iter()
                .any(|r| answered(&r.recommendation))
        });
        check_mesh(&set.message.object, answered, meshes)?;
        let with = plan.answering_at(set.log_time);
        let theirs_grip = theirs.map(as_grip);
        let ours = if plan.objective_from_answer {
            with.with_rules(rules_like(with.rules(), theirs_grip.as_ref()))
                .answer::<PoseSets>(&set.message)
        } else {
            with.answer::<PoseSets>(&set.message)
        };
        summary.sets += 1;
        summary.pose_sets += 1;
        summary.candidates += set.message.poses.len() as u64;
        if let (Some(theirs), Some(theirs_grip)) = (theirs, theirs_grip) {
            compare_pose_set(set, &ours, theirs, &theirs_grip, bag, summary);
        }
        if keep {
            kept.push(Recorded {
                message: ours,
                log_time: set.log_time,
                publish_time: set.publish_time,
            });
        }
    }
    Ok(kept)
}

/// Compares a pose set's new answer `ours` with its recorded one, `theirs` (`theirs_grip` as a
/// candidate set's answer), into `summary`.
fn compare_pose_set(
    set: &Recorded<<PoseSets as Kind>::Request>,
    ours: &PoseRecommendationSet,
    theirs: &PoseRecommendationSet,
    theirs_grip: &GripRecommendationSet,
    bag: &Bag,
    summary: &mut Summary,
) {
    summary.sets_compared += 1;
    // A set cut short (max_set_time, or the node stopping): its unsolved members as recorded.
    let ours_grip = as_grip(ours);
    let ours_grip = cut_like(&ours_grip, theirs_grip);
    let stand_in = uncast(&set.message);
    let mut differ = compare_set(&stand_in, &ours_grip, theirs_grip, bag, summary);
    for (k, (a, b)) in ours
        .recommendations
        .iter()
        .zip(&theirs.recommendations)
        .enumerate()
    {
        let label = || {
            let id = set.message.poses.get(k).map_or("", |p| p.id.as_str());
            format!(
                "pose set {:?} pose {k} {:?}",
                short_id(&set.message.id),
                short_id(id)
            )
        };
        differ |= compare_geometry(label, a, b, &bag.fields, summary);
    }
    if differ {
        summary.sets_differing += 1;
    }
    if ours_grip.status != GripRecommendationSet::STATUS_OK && ours_grip.recommendations.is_empty()
    {
        summary.in_refused_sets += set.message.poses.len() as u64;
    }
}

/// Whether a recorded answer got as far as the geometry: anything but a refusal as invalid input
/// (an unreadable mesh among them).
fn answered(r: &GripRecommendation) -> bool {
    r.status != GripRecommendation::STATUS_INVALID_INPUT
}

/// A mesh named by resource, read again here: when the recording answered with it (`answered`),
/// it must still be readable.
fn check_mesh(object: &GraspObject, answered: bool, meshes: &MeshCache) -> Result<(), ReplayError> {
    if !answered || object.mesh.is_empty() {
        return Ok(());
    }
    let scale = [object.scale.x, object.scale.y, object.scale.z];
    meshes
        .get(&object.mesh, scale)
        .map(|_| ())
        .map_err(|why| ReplayError::Mesh {
            resource: object.mesh.to_string(),
            why: Box::new(why),
        })
}

/// Whether a recorded answer's tool pose is compared: the recording has the field (one made
/// before it decodes it as zeros), and the pose is in the answer's header frame. A node with
/// `gravity_frame` set gives it in that frame, by TF at the candidate's stamp; `replay` has no
/// TF and gives it in the header frame, so it cannot say where such a pose would be.
fn tool_pose_compared(theirs: &PoseRecommendation, recorded: &RecordedFields) -> bool {
    recorded.has::<PoseRecommendation>("tool_pose")
        && theirs.tool_pose.header.frame_id == theirs.recommendation.header.frame_id
}

/// A pose set's answer as a candidate set's: the members' recommendations.
fn as_grip(r: &PoseRecommendationSet) -> GripRecommendationSet {
    GripRecommendationSet {
        header: r.header.clone(),
        set_id: r.set_id.clone(),
        recommendations: r
            .recommendations
            .iter()
            .map(|p| p.recommendation.clone())
            .collect(),
        ranking: r.ranking.clone(),
        ranked_by: r.ranked_by.clone(),
        status: r.status,
        message: r.message.clone(),
    }
}

/// The contacts, normals and centre of mass of a new answer against the recorded ones (NaN
/// equals NaN: a refused pose has none), and the tool pose where the recording has it
/// ([`tool_pose_compared`]); true when any differs beyond [`TOLERANCE`].
fn compare_geometry(
    label: impl FnOnce() -> String,
    ours: &PoseRecommendation,
    theirs: &PoseRecommendation,
    recorded: &RecordedFields,
    summary: &mut Summary,
) -> bool {
    let point = |p: &Point| [p.x, p.y, p.z];
    let vector = |v: &Vector3| [v.x, v.y, v.z];
    let tool = |p: &PoseStamped| {
        let (t, q) = (&p.pose.position, &p.pose.orientation);
        [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
    };
    let mut beyond = Vec::new();
    if tool_pose_compared(theirs, recorded) {
        let (a, b) = (&ours.tool_pose, &theirs.tool_pose);
        let gap = tool(a)
            .iter()
            .zip(&tool(b))
            .map(|(x, y)| number_gap(*x, *y))
            .fold(0.0, f64::max);
        let gap = if a.header == b.header { gap } else { 1.0 };
        if gap > 0.0 {
            summary.note_gap("tool_pose", gap);
        }
        if gap > TOLERANCE {
            beyond.push(format!("tool_pose (gap {gap:.3e})"));
        }
    }
    let fields: [(&'static str, [f64; 3], [f64; 3]); 5] = [
        (
            "contact_1",
            point(&ours.contact_1),
            point(&theirs.contact_1),
        ),
        (
            "contact_2",
            point(&ours.contact_2),
            point(&theirs.contact_2),
        ),
        ("normal_1", vector(&ours.normal_1), vector(&theirs.normal_1)),
        ("normal_2", vector(&ours.normal_2), vector(&theirs.normal_2)),
        (
            "center_of_mass",
            point(&ours.center_of_mass),
            point(&theirs.center_of_mass),
        ),
    ];
    for (field, a, b) in fields {
        let gap = a
            .iter()
            .zip(&b)
            .map(|(x, y)| number_gap(*x, *y))
            .fold(0.0, f64::max);
        if gap > 0.0 {
            summary.note_gap(field, gap);
        }
        if gap > TOLERANCE {
            beyond.push(format!("{field} (gap {gap:.3e})"));
        }
    }
    if beyond.is_empty() {
        return false;
    }
    keep_example(&mut summary.examples, || {
        format!("{}: {}", label(), beyond.join(", "))
    });
    true
}
