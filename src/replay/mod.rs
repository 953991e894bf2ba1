//! Replaying recordings: every recorded candidate is solved again, with the settings in force
//! when it was recorded ([`Plan`]), and compared, field by field, with the recommendation
//! recorded for it; every recorded set likewise ([`sets`]). Only the fields the recording has are
//! compared: a recording made before a message grew decodes with the new trailing fields at their
//! defaults, which say nothing.

mod poses;
mod sets;

use crate::answer::{Answering, PoseAnswerer, Rules, BEHIND_TANGENT_NOTE};
use crate::config::{Config, ConfigError};
use crate::kind::{Candidates, Key, Kind, Stream, Streams};
use crate::msg::{short_id, GraspCandidate, GripRecommendation};
use crate::record::bag::{keep_example, Bag, Recorded};
use crate::record::channels::RecordedFields;
use crate::record::settings::{SettingsError, SettingsRecord, METADATA_NAME};
use crate::solver::{Objective, Settings};
use grasp_orient_geometry::ClosingAxis;
use serde_yaml_ng::Value;
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
    /// ([`RECORDED_BEHIND_TANGENT`]) and answered now ([`answered_behind_tangent`]): counted as
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
fn pair<K: Kind>(stream: &Stream<K>) -> (Vec<Option<usize>>, u64) {
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

/// Why a recording cannot be replayed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReplayError {
    /// A settings record of the bag does not read.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The settings with the command line's overrides are refused.
    #[error("the recorded settings with the command line's overrides: {0}")]
    Overrides(ConfigError),
    /// A thread solving a share of the candidates failed.
    #[error("a replay worker failed: {0}")]
    Worker(String),
    /// A mesh a recorded pose was answered with cannot be read here.
    #[error(
        "mesh {resource} of a recorded pose cannot be read at replay time (package:// resolves \
         through AMENT_PREFIX_PATH): {why}"
    )]
    Mesh {
        /// The resource named in the recording.
        resource: String,
        /// Why it cannot be read.
        why: Box<grasp_orient_geometry::GeometryError>,
    },
}

/// A parameter set on the command line: its name and value.
pub type Override = (String, Value);

/// The settings each candidate of a recording is solved with.
///
/// A recording that carries settings records ([`crate::record::settings`]) is replayed with the
/// settings in force at each candidate's `log_time`; one without (made before they existed, or
/// by another writer) with the built-in config and the objective each recorded answer names.
/// Command-line overrides apply over both.
#[derive(Debug, Clone)]
pub struct Plan {
    /// From which `log_time` on each applies, in time order: settings, gripper rules and the
    /// closing axis of pose candidates, one mesh cache shared by all.
    timeline: Vec<(u64, Answering)>,
    /// For a recording without settings records.
    fallback: Answering,
    /// Whether each candidate is solved with the objective its recorded answer names.
    objective_from_answer: bool,
    /// The bag's settings records, overrides applied.
    pub recorded: Vec<SettingsRecord>,
    /// The parameters the command line set.
    pub overridden: Vec<String>,
}

impl Plan {
    /// The settings for the candidates of `bag`: its recorded settings, or else `base`; with
    /// `overrides` applied over either.
    pub(crate) fn for_bag(
        bag: &Bag,
        base: &Config,
        overrides: &[Override],
    ) -> Result<Self, ReplayError> {
        let apply = |config: &Config| -> Result<(Config, Settings), ReplayError> {
            let mut config = config.clone();
            for (name, value) in overrides {
                config
                    .set_value(name, value.clone())
                    .map_err(ReplayError::Overrides)?;
            }
            let settings = config.solver_settings().map_err(ReplayError::Overrides)?;
            Ok((config, settings))
        };
        let (base, base_settings) = apply(base)?;
        let meshes = pose_meshes();
        let mut recorded = Vec::new();
        for (name, entries) in &bag.metadata {
            if name == METADATA_NAME {
                recorded.push(SettingsRecord::from_metadata(entries)?);
            }
        }
        // In time order; records of one time keep their file order, the last one winning.
        recorded.sort_by_key(|r| r.since);
        let answering = |config: &Config, settings| {
            let poses = PoseAnswerer::sharing(config.closing_axis, meshes.clone());
            Answering::new(settings, config.rules(), poses)
        };
        let mut timeline = Vec::with_capacity(recorded.len());
        for record in &mut recorded {
            let (config, settings) = apply(&record.config)?;
            timeline.push((record.since, answering(&config, settings)));
            record.config = config;
        }
        let overridden: Vec<String> = overrides.iter().map(|(n, _)| n.clone()).collect();
        Ok(Self {
            objective_from_answer: timeline.is_empty()
                && !overridden.iter().any(|n| n == "objective"),
            fallback: answering(&base, base_settings),
            timeline,
            recorded,
            overridden,
        })
    }

    /// The same settings for every candidate, whatever the bag holds (for tests and benches).
    pub fn fixed(settings: Settings) -> Self {
        Self::fixed_with(settings, Rules::default())
    }

    /// [`Plan::fixed`] with gripper rules too.
    pub(crate) fn fixed_with(settings: Settings, rules: Rules) -> Self {
        let poses = PoseAnswerer::sharing(ClosingAxis::default(), pose_meshes());
        Self {
            timeline: Vec::new(),
            fallback: Answering::new(settings, rules, poses),
            objective_from_answer: true,
            recorded: Vec::new(),
            overridden: Vec::new(),
        }
    }

    /// Whether the bag carried its settings.
    pub(crate) fn settings_recorded(&self) -> bool {
        !self.timeline.is_empty()
    }

    /// What answers a candidate (or set, pose candidate, pose set) received at `log_time`: the
    /// settings of the last record from before it (the first record's for earlier ones).
    pub(crate) fn answering_at(&self, log_time: u64) -> &Answering {
        match self.index_at(log_time) {
            Some(i) => &self.timeline[i].1,
            None => &self.fallback,
        }
    }

    /// The meshes of the replay's pose candidates (one cache for every settings record).
    pub(crate) fn meshes(&self) -> &grasp_orient_geometry::MeshCache {
        self.fallback.poses().meshes()
    }

    /// The timeline entry in force at `log_time`: the last from before it, the first for earlier
    /// times; `None` without a timeline.
    fn index_at(&self, log_time: u64) -> Option<usize> {
        let after = self
            .timeline
            .partition_point(|(since, _)| *since <= log_time);
        after.checked_sub(1).or(self.timeline.first().map(|_| 0))
    }
}

/// Solves every candidate and every set of `bag` again as `plan` says and compares. The work is
/// shared among the machine's cores; `progress` hears of every 4096 candidates done.
pub fn replay(
    bag: &Bag,
    plan: &Plan,
    progress: impl Fn(u64) + Sync,
) -> Result<Summary, ReplayError> {
    let (mut summary, _) = replay_on_cores(bag, plan, false, &progress)?;
    summary.merge(sets::replay_sets(bag, plan, false).0);
    summary.merge(poses::replay_poses(bag, plan, false)?.0);
    Ok(summary)
}

/// The meshes of a replay's pose candidates: `package://` through this process's
/// `AMENT_PREFIX_PATH`.
fn pose_meshes() -> std::sync::Arc<grasp_orient_geometry::MeshCache> {
    std::sync::Arc::new(grasp_orient_geometry::MeshCache::new(
        grasp_orient_geometry::AmentIndex::from_env(),
        crate::answer::MESH_CACHE_BYTES,
    ))
}

/// [`replay`], also returning the new answers: each kind's in its stream's `answers`, one per
/// recorded request in the requests' order, each with its request's times.
pub(crate) fn replay_with_answers(
    bag: &Bag,
    plan: &Plan,
    progress: impl Fn(u64) + Sync,
) -> Result<(Summary, Streams), ReplayError> {
    let (mut summary, recommendations) = replay_on_cores(bag, plan, true, &progress)?;
    let (of_sets, sets) = sets::replay_sets(bag, plan, true);
    summary.merge(of_sets);
    let (of_poses, poses) = poses::replay_poses(bag, plan, true)?;
    summary.merge(of_poses);
    let mut answers = Streams::default();
    answers.candidates.answers = recommendations;
    answers.sets.answers = sets;
    answers.poses.answers = poses.recommendations;
    answers.pose_sets.answers = poses.sets;
    Ok((summary, answers))
}

/// One share of the candidates per core; the answers are kept only when asked for, since a
/// replay of millions of candidates need not hold them all. A share that fails fails the
/// replay: its counts and answers must not silently go missing.
fn replay_on_cores(
    bag: &Bag,
    plan: &Plan,
    keep: bool,
    progress: &(impl Fn(u64) + Sync),
) -> Result<(Summary, Vec<Recorded<GripRecommendation>>), ReplayError> {
    let (pairs, unmatched) = pair(&bag.streams.candidates);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = bag
        .streams
        .candidates
        .requests
        .len()
        .div_ceil(threads)
        .max(1);
    type Part = (Vec<Recorded<GripRecommendation>>, Summary);
    let parts: Result<Vec<Part>, ReplayError> = std::thread::scope(|scope| {
        let handles: Vec<_> = bag
            .streams
            .candidates
            .requests
            .chunks(chunk)
            .zip(pairs.chunks(chunk))
            .map(|(cands, pairs)| {
                scope.spawn(move || {
                    let mut part = Summary::default();
                    let mut answers = Vec::with_capacity(if keep { cands.len() } else { 0 });
                    for (k, (c, p)) in cands.iter().zip(pairs).enumerate() {
                        let theirs = p.map(|i| &bag.streams.candidates.answers[i].message);
                        let with = plan.answering_at(c.log_time);
                        let from_answer = plan.objective_from_answer;
                        let ours = check(
                            &c.message,
                            with,
                            from_answer,
                            theirs,
                            &bag.fields,
                            &mut part,
                        );
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
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .map_err(|e| ReplayError::Worker(panic_words(e.as_ref())))
            })
            .collect()
    });
    let parts = parts?;
    let mut summary = Summary {
        unmatched_recommendations: unmatched,
        ..Summary::default()
    };
    let mut answers = Vec::with_capacity(if keep {
        bag.streams.candidates.requests.len()
    } else {
        0
    });
    for (a, part) in parts {
        answers.extend(a);
        summary.merge(part);
    }
    Ok((summary, answers))
}

/// What a panicking thread said.
fn panic_words(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "it panicked".to_string())
}

/// Solves one candidate again and compares it with its recorded answer, if any.
fn check(
    candidate: &GraspCandidate,
    with: &Answering,
    objective_from_answer: bool,
    theirs: Option<&GripRecommendation>,
    fields: &RecordedFields,
    summary: &mut Summary,
) -> GripRecommendation {
    summary.candidates += 1;
    let recorded = theirs.filter(|_| objective_from_answer);
    let ours = solve_like(candidate, with, recorded);
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
    if answered_behind_tangent(ours, theirs) {
        summary.answered_behind_tangent += 1;
        return false;
    }
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

/// Answers `with` its settings and rules, and with the objective `recorded` names, if given.
fn solve_like(
    candidate: &GraspCandidate,
    with: &Answering,
    recorded: Option<&GripRecommendation>,
) -> GripRecommendation {
    match recorded {
        None => with.answer::<Candidates>(candidate),
        Some(r) => with
            .with_settings(objective_like(with.settings(), Some(r)))
            .answer::<Candidates>(candidate),
    }
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
    use crate::answer::answer;

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

    /// `docs/recordings.md`, *Refusals answered now*: today's answer stands for exactly the
    /// recorded refusal of a centre of mass behind a tangent, and for nothing else.
    #[test]
    fn a_recorded_behind_tangent_refusal_accepts_only_todays_answer() {
        let mut m = crate::msg::paper_cases().swap_remove(2);
        let (p1, n1) = (m.contact_1.clone(), m.normal_1.clone());
        m.center_of_mass.x = p1.x - 0.5 * n1.x + 0.3 * n1.y;
        m.center_of_mass.y = p1.y - 0.5 * n1.y - 0.3 * n1.x;
        let ours = answer(&m, &Settings::default());
        assert_eq!(
            ours.status,
            GripRecommendation::STATUS_OK,
            "{}",
            ours.message
        );
        let refusal = |contact: &str| {
            let mut r = crate::msg::convert::invalid(
                &m,
                &format!("center_of_mass lies outside the object: behind the surface tangent at {contact}"),
            );
            r.objective = "norm2".into();
            r
        };
        let theirs = refusal("contact_1");
        assert!(answered_behind_tangent(&ours, &theirs));
        let mut summary = Summary::default();
        let fields = RecordedFields::default();
        assert!(!compare_one(
            String::new,
            &ours,
            &theirs,
            &fields,
            &mut summary
        ));
        assert_eq!((summary.compared, summary.differing), (1, 0));
        assert_eq!(summary.answered_behind_tangent, 1);
        // The other contact, another status, other words, a refusal today, another candidate or
        // objective: differences as ever.
        assert!(!answered_behind_tangent(&ours, &refusal("contact_2")));
        let mut other = theirs.clone();
        other.status = GripRecommendation::STATUS_NO_FORCE_CLOSURE;
        assert!(!answered_behind_tangent(&ours, &other));
        let mut other = theirs.clone();
        other.message = other.message.replace("lies outside", "is outside").into();
        assert!(!answered_behind_tangent(&ours, &other));
        assert!(!answered_behind_tangent(&theirs, &theirs));
        let mut other = theirs.clone();
        other.candidate_id = "another".into();
        assert!(!answered_behind_tangent(&ours, &other));
        let mut other = theirs.clone();
        other.objective = "norm1".into();
        assert!(!answered_behind_tangent(&ours, &other));
        assert!(compare_one(
            String::new,
            &ours,
            &other,
            &fields,
            &mut summary
        ));
        assert_eq!(summary.differing, 1);
        // Without the note (an answer for another reason), it is a difference too.
        let mut plain = ours.clone();
        plain.message = "".into();
        assert!(!answered_behind_tangent(&plain, &theirs));
    }

    /// Every kind through replay's one path: a recording holding, of each kind, a request and
    /// the answer `Answering` gives it replays with every answer paired and compared and none
    /// differing; with each answer replaced by another (`Default`), each kind's answer differs.
    #[test]
    fn every_kind_replays_through_its_pair_and_answer() {
        use crate::answer::{each, Answer, VisitAnswer};
        struct Fill(Bag, bool);
        impl VisitAnswer for Fill {
            fn kind<K: Answer>(&mut self) {
                let request = K::Request::default();
                let answer = if self.1 {
                    Answering::from_env().answer::<K>(&request)
                } else {
                    K::Answer::default()
                };
                fn at<T>(message: T) -> Recorded<T> {
                    Recorded {
                        message,
                        log_time: 10,
                        publish_time: 10,
                    }
                }
                let stream = K::stream_mut(&mut self.0.streams);
                stream.requests.push(at(request));
                stream.answers.push(at(answer));
            }
        }
        let replayed = |answered: bool| {
            let mut fill = Fill(Bag::default(), answered);
            each(&mut fill);
            let plan = Plan::fixed(Settings::default());
            replay(&fill.0, &plan, |_| {}).expect("replays")
        };
        let same = replayed(true);
        assert_eq!(
            (
                same.candidates,
                same.pose_candidates,
                same.sets,
                same.pose_sets
            ),
            (2, 1, 2, 1),
            "one candidate and one pose candidate, one set and one pose set: {same:?}"
        );
        assert_eq!((same.compared, same.sets_compared), (2, 2), "{same:?}");
        assert_eq!((same.differing, same.sets_differing), (0, 0), "{same:?}");
        assert_eq!(
            (same.unmatched_recommendations, same.unmatched_set_answers),
            (0, 0)
        );
        let other = replayed(false);
        assert_eq!((other.compared, other.sets_compared), (2, 2), "{other:?}");
        assert_eq!((other.differing, other.sets_differing), (2, 2), "{other:?}");
    }

    #[test]
    fn a_failing_worker_fails_the_replay() {
        let cases = crate::msg::paper_cases();
        let mut bag = Bag::default();
        bag.streams.candidates.requests = (0..8192)
            .map(|i| Recorded {
                message: cases[i % 4].clone(),
                log_time: i as u64,
                publish_time: i as u64,
            })
            .collect();
        let plan = Plan::fixed(Settings::default());
        let calls = std::sync::atomic::AtomicU64::new(0);
        let result = replay_with_answers(&bag, &plan, |_| {
            if calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst) == 0 {
                panic!("a worker fails");
            }
        });
        match result {
            Err(ReplayError::Worker(why)) => assert_eq!(why, "a worker fails"),
            Err(e) => panic!("expected a worker failure, got {e}"),
            Ok((summary, answers)) => panic!(
                "a failed worker went unnoticed: {} candidates, {} answers",
                summary.candidates,
                answers.candidates.answers.len()
            ),
        }
        let (summary, answers) = replay_with_answers(&bag, &plan, |_| {}).expect("replays");
        assert_eq!(
            (summary.candidates, answers.candidates.answers.len()),
            (8192, 8192)
        );
    }

    #[test]
    fn each_candidate_gets_the_settings_in_force_at_its_time() {
        use crate::config::Config;
        use crate::record::settings::SettingsRecord;
        let record = |since, fsf| {
            let config = Config {
                friction_safety_factor: fsf,
                ..Config::default()
            };
            let entries = SettingsRecord {
                since,
                node: "/grasp_orient".into(),
                reason: "test".into(),
                config,
            }
            .to_metadata();
            (METADATA_NAME.to_string(), entries)
        };
        let bag = Bag {
            // In file order the later record comes first: time decides, not position.
            metadata: vec![record(100, 2.0), record(0, 1.5)],
            ..Bag::default()
        };
        let plan = Plan::for_bag(&bag, &Config::default(), &[]).expect("a plan");
        assert!(plan.settings_recorded());
        assert_eq!(plan.answering_at(0).settings().friction_safety_factor, 1.5);
        assert_eq!(plan.answering_at(99).settings().friction_safety_factor, 1.5);
        assert_eq!(
            plan.answering_at(100).settings().friction_safety_factor,
            2.0
        );
        assert_eq!(
            plan.answering_at(u64::MAX)
                .settings()
                .friction_safety_factor,
            2.0
        );
        let overrides = [(
            "friction_safety_factor".to_string(),
            Value::Number(1.25.into()),
        )];
        let plan = Plan::for_bag(&bag, &Config::default(), &overrides).expect("a plan");
        assert_eq!(plan.answering_at(0).settings().friction_safety_factor, 1.25);
        assert_eq!(
            plan.answering_at(200).settings().friction_safety_factor,
            1.25
        );
        assert_eq!(plan.overridden, ["friction_safety_factor"]);
        let plan = Plan::for_bag(&Bag::default(), &Config::default(), &[]).expect("a plan");
        assert!(!plan.settings_recorded());
        assert_eq!(*plan.answering_at(5).settings(), Settings::default());
    }
}
