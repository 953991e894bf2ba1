//! Replaying recorded sets: each candidate set is solved again as the node answered it, and
//! compared with its recorded answer: every recommendation like a single candidate's, the
//! ranking, and the fields of the set.
//!
//! "As the node answered it": with the settings and gripper rules in force when it was received
//! ([`Plan`]), and its own `max_grip_force` when above 0. A recording without settings records
//! gives the objective its recorded recommendations name, and the gripper drive and ranking its
//! `ranked_by` names (`internal_force`: grip force of coupled fingers, `finger_force`: of
//! independent ones, `gripping_power`: the objective); the rest comes from the replay's settings.
//!
//! The ranking passes when it holds the same candidates as the new one, in an order sorted by the
//! new answers' values within [`TOLERANCE`] (ties by `|wrist_rotation|`): candidates whose force
//! agrees to rounding may swap places.

use super::compare::{compare_one, pair, Summary, TOLERANCE};
use super::plan::{objective_like, Plan};
use crate::answer::{is_sorted_by, GripperDrive, RankBy, Rules};
use crate::kind::Sets;
use crate::msg::{short_id, GraspCandidateSet, GripRecommendation, GripRecommendationSet};
use crate::record::bag::{keep_example, Bag, Recorded};

/// `rules` with the drive and ranking a recorded answer's `ranked_by` names.
pub(super) fn rules_like(rules: &Rules, recorded: Option<&GripRecommendationSet>) -> Rules {
    let (rank_by, drive) = match recorded.map(|r| r.ranked_by.as_str()) {
        Some("internal_force") => (RankBy::GripForce, GripperDrive::Coupled),
        Some("finger_force") => (RankBy::GripForce, GripperDrive::Independent),
        Some("gripping_power") => (RankBy::Objective, rules.drive),
        _ => (rules.rank_by, rules.drive),
    };
    Rules {
        rank_by,
        drive,
        ..*rules
    }
}

/// Solves every recorded set again and compares it with its recorded answer; the new answers,
/// each with its set's times, when `keep`.
pub(super) fn replay_sets(
    bag: &Bag,
    plan: &Plan,
    keep: bool,
) -> (Summary, Vec<Recorded<GripRecommendationSet>>) {
    let (pairs, unmatched) = pair(&bag.streams.sets);
    let mut summary = Summary {
        unmatched_set_answers: unmatched,
        ..Summary::default()
    };
    let mut answers = Vec::with_capacity(if keep {
        bag.streams.sets.requests.len()
    } else {
        0
    });
    for (set, p) in bag.streams.sets.requests.iter().zip(pairs) {
        let theirs = p.map(|i| &bag.streams.sets.answers[i].message);
        let with = plan.answering_at(set.log_time);
        let ours = if plan.objective_from_answer {
            let first =
                theirs.and_then(|t| t.recommendations.iter().find(|r| !r.objective.is_empty()));
            with.with_settings(objective_like(with.settings(), first))
                .with_rules(rules_like(with.rules(), theirs))
                .answer::<Sets>(&set.message)
        } else {
            with.answer::<Sets>(&set.message)
        };
        summary.sets += 1;
        summary.candidates += set.message.candidates.len() as u64;
        if let Some(theirs) = theirs {
            summary.sets_compared += 1;
            // A set cut short (max_set_time, or the node stopping): its unsolved members as recorded.
            let ours = crate::answer::cut_like(&ours, theirs);
            if compare_set(&set.message, &ours, theirs, bag, &mut summary) {
                summary.sets_differing += 1;
            }
            if ours.status != GripRecommendationSet::STATUS_OK && ours.recommendations.is_empty() {
                summary.in_refused_sets += set.message.candidates.len() as u64;
            }
        }
        if keep {
            answers.push(Recorded {
                message: ours,
                log_time: set.log_time,
                publish_time: set.publish_time,
            });
        }
    }
    (summary, answers)
}

/// Compares a set's new answer with its recorded one; true when anything differs.
pub(super) fn compare_set(
    set: &GraspCandidateSet,
    ours: &GripRecommendationSet,
    theirs: &GripRecommendationSet,
    bag: &Bag,
    summary: &mut Summary,
) -> bool {
    let fields = &bag.fields;
    let has = |name: &str| fields.has::<GripRecommendationSet>(name);
    let mut unequal: Vec<&'static str> = [
        ("set_id", ours.set_id == theirs.set_id),
        ("ranked_by", ours.ranked_by == theirs.ranked_by),
        ("set status", !has("status") || ours.status == theirs.status),
        (
            "set message",
            !has("message") || ours.message == theirs.message,
        ),
        (
            "recommendations (count)",
            ours.recommendations.len() == theirs.recommendations.len(),
        ),
        ("ranking", same_ranking(ours, theirs)),
    ]
    .into_iter()
    .filter_map(|(field, same)| (!same).then_some(field))
    .collect();
    for field in &unequal {
        summary.note_gap(field, 1.0);
    }
    let mut members_differ = false;
    for (k, (a, b)) in ours
        .recommendations
        .iter()
        .zip(&theirs.recommendations)
        .enumerate()
    {
        let label = || {
            format!(
                "set {:?} candidate {k} {:?}",
                short_id(&set.id),
                short_id(set.candidates.get(k).map_or("", |c| c.id.as_str()))
            )
        };
        members_differ |= compare_one(label, a, b, fields, summary);
    }
    if !unequal.is_empty() {
        unequal.sort_unstable();
        keep_example(&mut summary.examples, || {
            format!("set {:?}: {}", short_id(&set.id), unequal.join(", "))
        });
    }
    members_differ || !unequal.is_empty()
}

/// Whether the recorded ranking holds the candidates of the new one, sorted by the new answers'
/// values (to [`TOLERANCE`]).
fn same_ranking(ours: &GripRecommendationSet, theirs: &GripRecommendationSet) -> bool {
    let mut a = ours.ranking.clone();
    let mut b = theirs.ranking.clone();
    a.sort_unstable();
    b.sort_unstable();
    if a != b {
        return false;
    }
    let recs: &[GripRecommendation] = &ours.recommendations;
    is_sorted_by(&theirs.ranking, recs, &theirs.ranked_by, TOLERANCE)
        .unwrap_or(ours.ranking == theirs.ranking)
}
