//! Comparing a new answer with its recorded one: which fields, within which tolerance, and what
//! a replay reports ([`Summary`]); pairing each recorded request with its recorded answer.

use crate::answer::BEHIND_TANGENT_NOTE;
use crate::kind::{Key, Kind, Stream};
use crate::msg::GripRecommendation;
use crate::record::bag::keep_example;
use crate::record::channels::RecordedFields;
use std::collections::{BTreeMap, HashMap, VecDeque};

/// Two numbers closer than this, relative to `max(1, |a|, |b|)`, are the same.
pub(crate) const TOLERANCE: f64 = 1e-9;

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
    /// Candidates of sets refused as a whole, again and in the recording: compared through the
    /// set's status and message, having no recommendations of their own.
    pub in_refused_sets: u64,
    /// Pose candidates answered again (counted in `candidates` too).
    pub pose_candidates: u64,
    /// Pose sets answered again (counted in `sets` too).
    pub pose_sets: u64,

    /// Compared candidates recorded as refused for a centre of mass behind a surface tangent
    /// ([`RECORDED_BEHIND_TANGENT`]) and answered now (`answered_behind_tangent`): counted as
    /// agreeing, and here.
    pub answered_behind_tangent: u64,
}

impl Summary {
    /// Adds the summary of a replay of other candidates.
    pub(crate) fn merge(&mut self, other: Summary) {
        self.candidates += other.candidates;
        self.compared += other.compared;
        self.differing += other.differing;
        self.unmatched_recommendations += other.unmatched_recommendations;
        self.sets += other.sets;
        self.sets_compared += other.sets_compared;
        self.sets_differing += other.sets_differing;
        self.unmatched_set_answers += other.unmatched_set_answers;
        self.in_refused_sets += other.in_refused_sets;
        self.pose_candidates += other.pose_candidates;
        self.pose_sets += other.pose_sets;

        self.answered_behind_tangent += other.answered_behind_tangent;
        for (field, gap) in other.largest {
            self.note_gap(field, gap);
        }
        for example in other.examples {
            keep_example(&mut self.examples, || example);
        }
    }

    /// Keeps `gap` if it is the largest seen for `field`.
    pub(crate) fn note_gap(&mut self, field: &'static str, gap: f64) {
        let largest = self.largest.entry(field).or_insert(0.0);
        *largest = largest.max(gap);
    }
}

pub(crate) fn number_gap(a: f64, b: f64) -> f64 {
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
const NUMBERS: [NumberField; 23] = [
    ("wrist_rotation", |r| r.wrist_rotation),
    ("rotation.x", |r| r.rotation.x),
    ("rotation.y", |r| r.rotation.y),
    ("rotation.z", |r| r.rotation.z),
    ("rotation.w", |r| r.rotation.w),
    ("gravity_direction.x", |r| r.gravity_direction.x),
    ("gravity_direction.y", |r| r.gravity_direction.y),
    ("gravity_direction.z", |r| r.gravity_direction.z),
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
    ("rotation_axis.x", |r| r.rotation_axis.x),
    ("rotation_axis.y", |r| r.rotation_axis.y),
    ("rotation_axis.z", |r| r.rotation_axis.z),
    ("gripping_power_nominal", |r| r.gripping_power_nominal),
];

/// Every list of numbers compared: a different length is a gap of 1.
const LISTS: [ListField; 2] = [
    ("local_minima", |r| &r.local_minima),
    ("local_minima_power", |r| &r.local_minima_power),
];

/// Every text and count compared: unequal is a gap of 1. The candidate's id and header pair a
/// single answer with its candidate, so they matter for members of a set, paired by place.
const EXACT: [ExactField; 10] = [
    ("candidate_id", |a, b| a.candidate_id == b.candidate_id),
    ("header.frame_id", |a, b| {
        a.header.frame_id == b.header.frame_id
    }),
    ("header.stamp", |a, b| a.header.stamp == b.header.stamp),
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
#[cfg(test)]
pub(crate) fn differences(
    ours: &GripRecommendation,
    recorded: &GripRecommendation,
) -> Vec<(&'static str, f64)> {
    differences_in(ours, recorded, &RecordedFields::default())
}

/// Every field of `ours` against `recorded` that the recording has (`fields`): `(field, gap)`
/// for each that differs; the others are not compared.
pub(crate) fn differences_in(
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

/// For each recorded request of kind `K`, the index of its recorded answer, and how many answers
/// matched no request. A node's recording answers in order, so that is tried first; otherwise
/// answers are matched by [`Kind::answer_key`], in order (which gives the same pairs when the
/// order holds).
pub(crate) fn pair<K: Kind>(stream: &Stream<K>) -> (Vec<Option<usize>>, u64) {
    let (asked, answers) = (&stream.requests, &stream.answers);
    let aligned = asked.len() == answers.len()
        && asked
            .iter()
            .zip(answers)
            .all(|(q, a)| K::request_key(&q.message) == K::answer_key(&a.message));
    if aligned {
        return ((0..asked.len()).map(Some).collect(), 0);
    }
    let mut by_key: HashMap<Key<'_>, VecDeque<usize>> = HashMap::with_capacity(answers.len());
    for (i, a) in answers.iter().enumerate() {
        by_key
            .entry(K::answer_key(&a.message))
            .or_default()
            .push_back(i);
    }
    let pairs: Vec<Option<usize>> = asked
        .iter()
        .map(|q| {
            by_key
                .get_mut(&K::request_key(&q.message))
                .and_then(VecDeque::pop_front)
        })
        .collect();
    let unmatched = by_key.values().map(|q| q.len() as u64).sum();
    (pairs, unmatched)
}

/// Compares one new answer with its recorded one on the recorded fields; true when it differs.
/// `label` names the candidate in the report.
pub(crate) fn compare_one(
    label: impl FnOnce() -> String,
    ours: &GripRecommendation,
    theirs: &GripRecommendation,
    fields: &RecordedFields,
    summary: &mut Summary,
) -> bool {
    summary.compared += 1;
    if answered_behind_tangent(ours, theirs) {
        summary.answered_behind_tangent += 1;
        return false;
    }
    let reworded;
    let theirs = match inline_refusal_today(&theirs.message) {
        Some(message) => {
            reworded = GripRecommendation {
                message: message.into(),
                ..theirs.clone()
            };
            &reworded
        }
        None => theirs,
    };
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

/// A recorded refusal of an inline mesh beyond `max_inline_mesh_triangles` in 0.1.0's words,
/// which gave the mesh's count (`object.inline_mesh has 300000 triangles, more than
/// max_inline_mesh_triangles (250000); send a coarser mesh`, `… has 900001 vertices, more than 3 x
/// max_inline_mesh_triangles (750000)`), in today's, which name only the bound (the node no
/// longer decodes a mesh beyond it whole, so it does not know the count): the same refusal.
/// `None` for any other message.
fn inline_refusal_today(message: &str) -> Option<String> {
    let rest = message.strip_prefix("invalid input: object.inline_mesh has ")?;
    let (count, rest) = rest.split_once(' ')?;
    if count.is_empty() || !count.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    ["triangles", "vertices"].iter().find_map(|what| {
        let bound = rest.strip_prefix(what)?.strip_prefix(", more than ")?;
        Some(format!(
            "invalid input: object.inline_mesh has more {what} than {bound}"
        ))
    })
}

/// How recordings made before objects needed not be convex refused a candidate whose centre of
/// mass lies behind the surface tangent at a contact (the contact follows).
pub const RECORDED_BEHIND_TANGENT: &str =
    "invalid input: center_of_mass lies outside the object: behind the surface tangent at ";

/// Whether `theirs` is exactly that recorded refusal (status 2, [`RECORDED_BEHIND_TANGENT`] and
/// a contact) and `ours` is today's answer to it: not refused, its `message` noting
/// ([`BEHIND_TANGENT_NOTE`]) the contact the refusal named, for the same candidate (id, header)
/// and objective. Every other difference stays a difference (`docs/recordings.md`).
pub(crate) fn answered_behind_tangent(
    ours: &GripRecommendation,
    theirs: &GripRecommendation,
) -> bool {
    let Some(contact) = theirs.message.strip_prefix(RECORDED_BEHIND_TANGENT) else {
        return false;
    };
    let named = ours
        .message
        .split("; ")
        .filter_map(|note| note.strip_prefix(BEHIND_TANGENT_NOTE))
        .any(|rest| {
            let contacts = rest.split(" (").next().unwrap_or(rest);
            contacts.split(" and ").any(|c| c == contact)
        });
    theirs.status == GripRecommendation::STATUS_INVALID_INPUT
        && matches!(contact, "contact_1" | "contact_2")
        && ours.status != GripRecommendation::STATUS_INVALID_INPUT
        && named
        && ours.candidate_id == theirs.candidate_id
        && ours.header == theirs.header
        && ours.objective == theirs.objective
}
