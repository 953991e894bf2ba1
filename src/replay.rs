//! Replaying recordings: every recorded candidate is solved again and compared, field by field,
//! with the recommendation recorded for it; every recorded set likewise ([`sets`]). Only the
//! fields the recording has are compared: a recording made before a message grew decodes with
//! the new trailing fields at their defaults, which say nothing.

mod sets;

use crate::msg::{clip, short_id, GraspCandidate, GripRecommendation};
use crate::record::bag::{keep_example, Bag, Recorded};
use crate::record::channels::RecordedFields;
use crate::sets::{answer_one, Rules};
use crate::solver::{Objective, Settings};
use std::collections::{BTreeMap, HashMap, VecDeque};

/// Two numbers closer than this, relative to `max(1, |a|, |b|)`, are the same.
pub const TOLERANCE: f64 = 1e-9;

/// How one replay went.
#[derive(Debug, Clone, Default)]
pub struct Summary {
    /// Candidates solved again.
    pub candidates: u64,
    /// Of them, with a recorded recommendation to compare with.
    pub compared: u64,
    /// Of those, differing beyond tolerance in at least one field.
    pub differing: u64,
    /// Largest difference seen per field (0 for equal, 1 for unequal text or counts).
    pub largest: BTreeMap<&'static str, f64>,
    /// The first few differences, readable.
    pub examples: Vec<String>,
    /// Recorded recommendations no candidate matched.
    pub unmatched_recommendations: u64,
    /// Candidate sets solved again (their candidates count in `candidates` too).
    pub sets: u64,
    /// Of them, with a recorded answer to compare with.
    pub sets_compared: u64,
    /// Of those, differing in any recommendation, the ranking or a field of the set.
    pub sets_differing: u64,
    /// Recorded set answers no set matched.
    pub unmatched_set_answers: u64,
}

impl Summary {
    /// Adds the summary of a replay of other candidates.
    pub fn merge(&mut self, other: Summary) {
        self.candidates += other.candidates;
        self.compared += other.compared;
        self.differing += other.differing;
        self.unmatched_recommendations += other.unmatched_recommendations;
        self.sets += other.sets;
        self.sets_compared += other.sets_compared;
        self.sets_differing += other.sets_differing;
        self.unmatched_set_answers += other.unmatched_set_answers;
        for (field, gap) in other.largest {
            self.note_gap(field, gap);
        }
        for example in other.examples {
            keep_example(&mut self.examples, || example);
        }
    }

    /// Keeps `gap` if it is the largest seen for `field`.
    fn note_gap(&mut self, field: &'static str, gap: f64) {
        let largest = self.largest.entry(field).or_insert(0.0);
        *largest = largest.max(gap);
    }
}

fn number_gap(a: f64, b: f64) -> f64 {
    if a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()) {
        0.0
    } else if !a.is_finite() || !b.is_finite() {
        if a == b {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        (a - b).abs() / 1f64.max(a.abs()).max(b.abs())
    }
}

/// A number of a recommendation, by field name.
type NumberField = (&'static str, fn(&GripRecommendation) -> f64);
/// A list of numbers of a recommendation, by field name.
type ListField = (&'static str, fn(&GripRecommendation) -> &[f64]);
/// Whether two recommendations agree on a text or count field, by field name.
type ExactField = (
    &'static str,
    fn(&GripRecommendation, &GripRecommendation) -> bool,
);

/// Every number compared, in report order.
const NUMBERS: [NumberField; 16] = [
    ("wrist_rotation", |r| r.wrist_rotation),
    ("rotation.z", |r| r.rotation.z),
    ("rotation.w", |r| r.rotation.w),
    ("gravity_direction.x", |r| r.gravity_direction.x),
    ("gravity_direction.y", |r| r.gravity_direction.y),
    ("gravity_angle", |r| r.gravity_angle),
    ("gripping_power", |r| r.gripping_power),
    ("internal_force", |r| r.internal_force),
    ("contact_forces", |r| r.contact_forces[0]),
    ("contact_forces", |r| r.contact_forces[1]),
    ("contact_forces", |r| r.contact_forces[2]),
    ("contact_forces", |r| r.contact_forces[3]),
    ("gripping_power_current", |r| r.gripping_power_current),
    ("internal_force_current", |r| r.internal_force_current),
    ("finger_force", |r| r.finger_force),
    ("finger_force_current", |r| r.finger_force_current),
];

/// Every list of numbers compared: a different length is a gap of 1.
const LISTS: [ListField; 2] = [
    ("local_minima", |r| &r.local_minima),
    ("local_minima_power", |r| &r.local_minima_power),
];

/// Every text and count compared: unequal is a gap of 1.
const EXACT: [ExactField; 7] = [
    ("status", |a, b| a.status == b.status),
    ("message", |a, b| a.message == b.message),
    ("grasp_case", |a, b| a.grasp_case == b.grasp_case),
    ("local_minima_labels", |a, b| {
        a.local_minima_labels == b.local_minima_labels
    }),
    ("objective", |a, b| a.objective == b.objective),
    ("recommended_label", |a, b| {
        a.recommended_label == b.recommended_label
    }),
    ("candidate_c", |a, b| a.candidate_c == b.candidate_c),
];

/// Every field of `ours` against `recorded`: `(field, gap)` for each that differs.
pub fn differences(
    ours: &GripRecommendation,
    recorded: &GripRecommendation,
) -> Vec<(&'static str, f64)> {
    differences_in(ours, recorded, &RecordedFields::default())
}

/// [`differences`] on the fields the recording has (`fields`); the others are not compared.
pub fn differences_in(
    ours: &GripRecommendation,
    recorded: &GripRecommendation,
    fields: &RecordedFields,
) -> Vec<(&'static str, f64)> {
    // "rotation.z" is a part of "rotation".
    let has = |name: &str| fields.has::<GripRecommendation>(name.split('.').next().unwrap_or(name));
    let numbers = NUMBERS
        .iter()
        .map(|(field, get)| (*field, number_gap(get(ours), get(recorded))));
    let lists = LISTS.iter().map(|(field, get)| {
        let (a, b) = (get(ours), get(recorded));
        let gap = if a.len() == b.len() {
            a.iter()
                .zip(b)
                .map(|(x, y)| number_gap(*x, *y))
                .fold(0.0, f64::max)
        } else {
            1.0
        };
        (*field, gap)
    });
    let exact = EXACT
        .iter()
        .map(|(field, same)| (*field, if same(ours, recorded) { 0.0 } else { 1.0 }));
    numbers
        .chain(lists)
        .chain(exact)
        .filter(|(field, gap)| *gap > 0.0 && has(field))
        .collect()
}

/// The key that pairs a recommendation with its candidate: id and header, cut to the length an
/// answer carries them at.
type Key<'a> = (&'a str, i32, u32, &'a str);

fn key<'a>(id: &'a str, header: &'a crate::msg::Header) -> Key<'a> {
    (
        clip(id),
        header.stamp.sec,
        header.stamp.nanosec,
        clip(&header.frame_id),
    )
}

/// For each candidate, the index of its recorded recommendation. A node's recording answers
/// candidates in order, so that is tried first; otherwise answers are matched by key, in order.
fn pair(bag: &Bag) -> (Vec<Option<usize>>, u64) {
    let cands = &bag.candidates;
    let recs = &bag.recommendations;
    let aligned = cands.len() == recs.len()
        && cands.iter().zip(recs).all(|(c, r)| {
            key(&c.message.id, &c.message.header) == key(&r.message.candidate_id, &r.message.header)
        });
    if aligned {
        return ((0..cands.len()).map(Some).collect(), 0);
    }
    let mut by_key: HashMap<Key<'_>, VecDeque<usize>> = HashMap::with_capacity(recs.len());
    for (i, r) in recs.iter().enumerate() {
        by_key
            .entry(key(&r.message.candidate_id, &r.message.header))
            .or_default()
            .push_back(i);
    }
    let pairs: Vec<Option<usize>> = cands
        .iter()
        .map(|c| {
            by_key
                .get_mut(&key(&c.message.id, &c.message.header))
                .and_then(VecDeque::pop_front)
        })
        .collect();
    let unmatched = by_key.values().map(|q| q.len() as u64).sum();
    (pairs, unmatched)
}

/// Solves every candidate and every set of `bag` again with `settings` and `rules` (and, for
/// each, the objective its recorded answer names) and compares. The work is shared among the
/// machine's cores; `progress` hears of every 4096 candidates done.
pub fn replay(
    bag: &Bag,
    settings: &Settings,
    rules: &Rules,
    progress: impl Fn(u64) + Sync,
) -> Summary {
    let mut summary = replay_on_cores(bag, settings, rules, false, &progress).0;
    summary.merge(sets::replay_sets(bag, settings, rules, false).0);
    summary
}

/// The new answers of a replay, each with its candidate's (or set's) times.
#[derive(Debug, Default)]
pub struct Answers {
    /// One per recorded candidate, in order.
    pub recommendations: Vec<Recorded<GripRecommendation>>,
    /// One per recorded set, in order.
    pub sets: Vec<Recorded<crate::msg::GripRecommendationSet>>,
}

/// [`replay`], also returning the new answers.
pub fn replay_with_answers(
    bag: &Bag,
    settings: &Settings,
    rules: &Rules,
    progress: impl Fn(u64) + Sync,
) -> (Summary, Answers) {
    let (mut summary, recommendations) = replay_on_cores(bag, settings, rules, true, &progress);
    let (of_sets, sets) = sets::replay_sets(bag, settings, rules, true);
    summary.merge(of_sets);
    (
        summary,
        Answers {
            recommendations,
            sets,
        },
    )
}

/// One share of the candidates per core; the answers are kept only when asked for, since a
/// replay of millions of candidates need not hold them all.
fn replay_on_cores(
    bag: &Bag,
    settings: &Settings,
    rules: &Rules,
    keep: bool,
    progress: &(impl Fn(u64) + Sync),
) -> (Summary, Vec<Recorded<GripRecommendation>>) {
    let (pairs, unmatched) = pair(bag);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = bag.candidates.len().div_ceil(threads).max(1);
    let parts: Vec<(Vec<Recorded<GripRecommendation>>, Summary)> = std::thread::scope(|scope| {
        let handles: Vec<_> = bag
            .candidates
            .chunks(chunk)
            .zip(pairs.chunks(chunk))
            .map(|(cands, pairs)| {
                scope.spawn(move || {
                    let mut part = Summary::default();
                    let mut answers = Vec::with_capacity(if keep { cands.len() } else { 0 });
                    for (k, (c, p)) in cands.iter().zip(pairs).enumerate() {
                        let theirs = p.map(|i| &bag.recommendations[i].message);
                        let ours =
                            check(&c.message, settings, rules, theirs, &bag.fields, &mut part);
                        if keep {
                            answers.push(Recorded {
                                message: ours,
                                log_time: c.log_time,
                                publish_time: c.publish_time,
                            });
                        }
                        if (k + 1) % 4096 == 0 {
                            progress(4096);
                        }
                    }
                    (answers, part)
                })
            })
            .collect();
        handles.into_iter().filter_map(|h| h.join().ok()).collect()
    });
    let mut summary = Summary {
        unmatched_recommendations: unmatched,
        ..Summary::default()
    };
    let mut answers = Vec::with_capacity(if keep { bag.candidates.len() } else { 0 });
    for (a, part) in parts {
        answers.extend(a);
        summary.merge(part);
    }
    (summary, answers)
}

/// Solves one candidate again and compares it with its recorded answer, if any.
fn check(
    candidate: &GraspCandidate,
    settings: &Settings,
    rules: &Rules,
    theirs: Option<&GripRecommendation>,
    fields: &RecordedFields,
    summary: &mut Summary,
) -> GripRecommendation {
    summary.candidates += 1;
    let ours = solve_like(candidate, settings, rules, theirs);
    if let Some(theirs) = theirs {
        let label = || format!("candidate {:?}", short_id(&candidate.id));
        compare_one(label, &ours, theirs, fields, summary);
    }
    ours
}

/// Compares one new answer with its recorded one on the recorded fields; true when it differs.
/// `label` names the candidate in the report.
fn compare_one(
    label: impl FnOnce() -> String,
    ours: &GripRecommendation,
    theirs: &GripRecommendation,
    fields: &RecordedFields,
    summary: &mut Summary,
) -> bool {
    summary.compared += 1;
    let diffs = differences_in(ours, theirs, fields);
    for (field, gap) in &diffs {
        summary.note_gap(field, *gap);
    }
    let beyond: Vec<_> = diffs.iter().filter(|(_, g)| *g > TOLERANCE).collect();
    if beyond.is_empty() {
        return false;
    }
    summary.differing += 1;
    keep_example(&mut summary.examples, || {
        format!(
            "{}: {}",
            label(),
            beyond
                .iter()
                .map(|(f, g)| format!("{f} (gap {g:.3e})"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    });
    true
}

/// Solves as the recording did: with the objective the recorded answer names, if any.
fn solve_like(
    candidate: &GraspCandidate,
    settings: &Settings,
    rules: &Rules,
    recorded: Option<&GripRecommendation>,
) -> GripRecommendation {
    answer_one(candidate, &objective_like(settings, recorded), rules)
}

/// `settings` with the objective `recorded` names, if any.
fn objective_like(settings: &Settings, recorded: Option<&GripRecommendation>) -> Settings {
    let objective = recorded
        .and_then(|r| Objective::from_name(&r.objective))
        .unwrap_or(settings.objective);
    Settings {
        objective,
        ..*settings
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::answer;

    #[test]
    fn equal_answers_have_no_differences_and_changed_ones_are_named() {
        let c = crate::msg::paper_cases().swap_remove(0);
        let a = answer(&c, &Settings::default());
        assert!(differences(&a, &a.clone()).is_empty());
        let mut b = a.clone();
        b.gripping_power *= 1.0 + 1e-6;
        b.local_minima_labels[0] = "X".into();
        let d = differences(&a, &b);
        assert!(d
            .iter()
            .any(|(f, g)| *f == "gripping_power" && *g > TOLERANCE));
        assert!(d.iter().any(|(f, _)| *f == "local_minima_labels"));
        let nan = answer(&GraspCandidate::default(), &Settings::default());
        assert!(
            differences(&nan, &nan.clone()).is_empty(),
            "NaN equals NaN here"
        );
    }
}
