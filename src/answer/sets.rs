//! Many candidates at once: the force a gripper is set to, the gripper's limit, and the answer to
//! a whole [`GraspCandidateSet`], its candidates ranked by the force they need.
//!
//! # The grip force
//! A parallel gripper's force setting (`control_msgs/GripperCommand.max_effort`, a Franka
//! `Grasp.force`, a Robotiq force register) is a push along the closing line, the line through the
//! two contacts. With coupled fingers (one motor through a rack, pinion or linkage) the motor gives
//! the mean of the two pushes, which is exactly `internal_force`; with independently driven fingers
//! each gives its own push, and the larger, `finger_force`, is what each must be able to give
//! (derivation in `crates/solver/src/planar/finger.rs`). [`GripperDrive`] picks which of the two
//! is *the grip force* compared with `max_grip_force` and used by the ranking.
//!
//! # Rules
//! - A candidate that can be held (status 0) but needs more grip force than `max_grip_force`
//!   (when above 0) gets status 3 (`STATUS_EXCEEDS_GRIPPER`) with every field still filled; single
//!   candidates and the members of a set alike ([`answer_one`]).
//! - The ranking lists the indices of the candidates with status 0, least force first: the grip
//!   force (`rank_by: grip_force`) or the objective's value, `gripping_power`
//!   (`rank_by: objective`). Ties go to the smaller `|wrist_rotation|`, then to the lower index.
//! - A set larger than `max_set_size` is refused as a whole with `STATUS_TOO_LARGE` before any
//!   candidate is solved; a set whose own fields are bad with `STATUS_INVALID_INPUT`. A set's own
//!   `max_grip_force` of 0 means the node's.
//! - A set whose solving is stopped ([`answer_set_within`]: its `max_set_time` ran out, or the node
//!   is stopping) gets `STATUS_INCOMPLETE`, and its members not solved `STATUS_NOT_SOLVED`; a set
//!   the node cannot take now ([`busy`]) `STATUS_BUSY`, nothing solved.
//! - The node's `center_of_mass_tolerance` and `mass_tolerance` ([`DefaultTolerances`]) apply to
//!   a candidate that leaves its own at zero; a candidate's own non-zero tolerance wins.

use super::candidate::{answer, answer_in_full, Answered};
use crate::msg::{
    clip, CompactString, GraspCandidate, GraspCandidateSet, GripRecommendation,
    GripRecommendationSet, MAX_TEXT_BYTES,
};
use crate::solver::Settings;
use std::borrow::Cow;
use std::cmp::Ordering;

/// How the fingers of the gripper are driven: which force is the grip force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GripperDrive {
    /// One motor moves both fingers: the grip force is `internal_force`, the common-mode squeeze.
    #[default]
    Coupled,
    /// Each finger has its own drive: the grip force is `finger_force`, the larger push.
    Independent,
}

impl GripperDrive {
    /// The name in params files and on the command line.
    pub(crate) const fn name(&self) -> &'static str {
        match self {
            GripperDrive::Coupled => "coupled",
            GripperDrive::Independent => "independent",
        }
    }

    /// The [`GripRecommendation`] field that holds the grip force.
    pub(crate) fn field(&self) -> &'static str {
        match self {
            GripperDrive::Coupled => "internal_force",
            GripperDrive::Independent => "finger_force",
        }
    }

    /// The grip force of an answer, N.
    pub(crate) fn grip_force(&self, r: &GripRecommendation) -> f64 {
        match self {
            GripperDrive::Coupled => r.internal_force,
            GripperDrive::Independent => r.finger_force,
        }
    }
}

/// What the ranking of a set sorts by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RankBy {
    /// The grip force that [`GripperDrive`] picks.
    #[default]
    GripForce,
    /// The objective's value at the recommendation, `gripping_power`.
    Objective,
}

impl RankBy {
    /// The name in params files and on the command line.
    pub(crate) const fn name(&self) -> &'static str {
        match self {
            RankBy::GripForce => "grip_force",
            RankBy::Objective => "objective",
        }
    }
}

/// The node's tolerances, parameters `center_of_mass_tolerance` and `mass_tolerance`:
/// what a candidate that leaves its own at zero is answered with.
///
/// Per field, the candidate's own wins when it is non-zero: its `center_of_mass_tolerance` when
/// any of its three components is non-zero (so a candidate can say "known exactly along y" with
/// `(0.01, 0, 0)`), its `mass_tolerance` when non-zero; otherwise the node's. All zero (the
/// default) leaves every candidate as it is, so the answers are today's bit for bit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DefaultTolerances {
    /// Half-widths of the box around the centre of mass along the candidate frame's axes, m.
    pub center_of_mass: [f64; 3],
    /// ± kg.
    pub mass: f64,
}

impl DefaultTolerances {
    /// `m` with the node's tolerances where its own are zero (borrowed when nothing changes).
    pub(crate) fn apply<'a>(&self, m: &'a GraspCandidate) -> Cow<'a, GraspCandidate> {
        let t = &m.center_of_mass_tolerance;
        let own_box = t.x != 0.0 || t.y != 0.0 || t.z != 0.0;
        let fill_box = !own_box && self.center_of_mass != [0.0; 3];
        let fill_mass = m.mass_tolerance == 0.0 && self.mass != 0.0;
        if !fill_box && !fill_mass {
            return Cow::Borrowed(m);
        }
        let mut out = m.clone();
        if fill_box {
            let [x, y, z] = self.center_of_mass;
            out.center_of_mass_tolerance = crate::msg::Vector3 { x, y, z };
        }
        if fill_mass {
            out.mass_tolerance = self.mass;
        }
        Cow::Owned(out)
    }
}

/// The rules for answering with a gripper in mind: the node's parameters `gripper_drive`,
/// `max_grip_force`, `rank_by` and `max_set_size`, and its default tolerances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rules {
    /// Which force is the grip force.
    pub drive: GripperDrive,
    /// The most grip force the gripper gives, N; 0 for no limit.
    pub max_grip_force: f64,
    /// What the ranking sorts by.
    pub rank_by: RankBy,
    /// The most candidates a set may hold.
    pub max_set_size: usize,
    /// The tolerances of a candidate that gives none.
    pub tolerances: DefaultTolerances,
}

impl Default for Rules {
    fn default() -> Self {
        Self {
            drive: GripperDrive::default(),
            max_grip_force: 0.0,
            rank_by: RankBy::default(),
            max_set_size: DEFAULT_MAX_SET_SIZE,
            tolerances: DefaultTolerances::default(),
        }
    }
}

/// The default of `max_set_size`: about 2.5 MB of candidates, solved in a few milliseconds.
pub(crate) const DEFAULT_MAX_SET_SIZE: usize = 10_000;

impl Rules {
    /// The [`GripRecommendation`] field the ranking sorts by, as `ranked_by` names it.
    pub(crate) fn ranked_by(&self) -> &'static str {
        match self.rank_by {
            RankBy::GripForce => self.drive.field(),
            RankBy::Objective => "gripping_power",
        }
    }

    /// The value the ranking sorts by.
    fn rank_key(&self, r: &GripRecommendation) -> f64 {
        match self.rank_by {
            RankBy::GripForce => self.drive.grip_force(r),
            RankBy::Objective => r.gripping_power,
        }
    }
}

/// Gives status 3 to an answer with status 0 whose grip force exceeds `max_grip_force` (N; 0 for
/// no limit). Every other field is kept.
pub(crate) fn apply_limit(r: &mut GripRecommendation, drive: GripperDrive, max_grip_force: f64) {
    if r.status != GripRecommendation::STATUS_OK || max_grip_force <= 0.0 {
        return;
    }
    let grip = drive.grip_force(r);
    if grip > max_grip_force {
        r.status = GripRecommendation::STATUS_EXCEEDS_GRIPPER;
        r.message = compact_str::format_compact!(
            "exceeds the gripper: needs {grip:.3} N of grip force ({} with gripper_drive {}), \
             more than max_grip_force {max_grip_force} N",
            drive.field(),
            drive.name()
        );
    }
}

/// The answer to one candidate under `rules`: the node's tolerances where the candidate gives
/// none, [`answer`], then the gripper's limit.
pub(crate) fn answer_one(
    m: &GraspCandidate,
    settings: &Settings,
    rules: &Rules,
) -> GripRecommendation {
    let mut r = answer(&rules.tolerances.apply(m), settings);
    apply_limit(&mut r, rules.drive, rules.max_grip_force);
    r
}

/// [`answer_one`], with the 3D solution of a spatial grasp (for its markers).
pub(crate) fn answer_one_in_full(
    m: &GraspCandidate,
    settings: &Settings,
    rules: &Rules,
) -> Answered {
    let mut out = answer_in_full(&rules.tolerances.apply(m), settings);
    apply_limit(&mut out.reply, rules.drive, rules.max_grip_force);
    out
}

/// The indices of the answers with status 0, least `Rules::ranked_by` first; ties go to the
/// smaller `|wrist_rotation|`, then to the lower index.
pub fn rank(recommendations: &[GripRecommendation], rules: &Rules) -> Vec<u32> {
    // Each float as the integer `f64::total_cmp` compares, computed once per answer rather than
    // twice per comparison: the same order, and the sort of 1,000 took 3.7 % of a set's
    // instructions with the floats.
    let mut keyed: Vec<(i64, i64, u32)> = recommendations
        .iter()
        .zip(0u32..)
        .filter(|(r, _)| r.status == GripRecommendation::STATUS_OK)
        .map(|(r, i)| {
            (
                total_order(rules.rank_key(r)),
                total_order(r.wrist_rotation.abs()),
                i,
            )
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, _, i)| i).collect()
}

/// The integer whose order is `f64::total_cmp`'s (its documented definition): negative floats'
/// magnitude bits flipped, so that the two's-complement order of the bits is the total order.
fn total_order(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    bits ^ (((bits >> 63) as u64) >> 1) as i64
}

/// Why a set is refused as a whole, if it is: its status and message.
pub(crate) fn refusal(set: &GraspCandidateSet, rules: &Rules) -> Option<(u8, String)> {
    let n = set.candidates.len();
    if n > rules.max_set_size {
        return Some((
            GripRecommendationSet::STATUS_TOO_LARGE,
            format!(
                "the set holds {n} candidates, more than max_set_size {}: split it, or raise \
                 max_set_size",
                rules.max_set_size
            ),
        ));
    }
    let limit = set.max_grip_force;
    if !(limit.is_finite() && limit >= 0.0) {
        return Some((
            GripRecommendationSet::STATUS_INVALID_INPUT,
            format!(
                "invalid input: max_grip_force must be a finite number >= 0 N (0: the node's \
                 max_grip_force), got {limit}"
            ),
        ));
    }
    for (field, text) in [("id", &set.id), ("header.frame_id", &set.header.frame_id)] {
        if text.len() > MAX_TEXT_BYTES {
            return Some((
                GripRecommendationSet::STATUS_INVALID_INPUT,
                format!(
                    "invalid input: {field} of the set is {} bytes long; at most {MAX_TEXT_BYTES} \
                     are accepted",
                    text.len()
                ),
            ));
        }
    }
    None
}

/// The empty answer to `set`: header (frame cut to 1024 bytes), `set_id` and `ranked_by` filled,
/// no recommendations.
pub(crate) fn empty_answer(set: &GraspCandidateSet, rules: &Rules) -> GripRecommendationSet {
    let mut header = set.header.clone();
    header.frame_id = clip(&header.frame_id).into();
    GripRecommendationSet {
        header,
        set_id: clip(&set.id).into(),
        recommendations: Vec::new(),
        ranking: Vec::new(),
        ranked_by: CompactString::const_new(rules.ranked_by()),
        status: GripRecommendationSet::STATUS_OK,
        message: CompactString::default(),
    }
}

/// The answer to a set the node cannot take now, `max_queued` sets (parameter `max_queued_sets`)
/// already waiting to be solved: `STATUS_BUSY` and nothing solved, or the set's own refusal (too
/// large, bad fields) when it has one, which sending it again would not cure.
pub fn busy(set: &GraspCandidateSet, rules: &Rules, max_queued: usize) -> GripRecommendationSet {
    let mut out = empty_answer(set, rules);
    let (status, message) = refusal(set, rules).unwrap_or_else(|| {
        (
            GripRecommendationSet::STATUS_BUSY,
            format!(
                "busy: {max_queued} sets already wait to be solved (max_queued_sets \
                 {max_queued}); nothing was solved: send the set again later"
            ),
        )
    });
    out.status = status;
    out.message = message.into();
    out
}

/// The answer refusing `set` as a whole with status 2 (invalid input) and `why`, nothing solved:
/// for a set the node cannot answer at all (a transform it needs is not there).
pub(crate) fn invalid_set(
    set: &GraspCandidateSet,
    rules: &Rules,
    why: &str,
) -> GripRecommendationSet {
    let mut out = empty_answer(set, rules);
    out.status = GripRecommendationSet::STATUS_INVALID_INPUT;
    out.message = compact_str::format_compact!("invalid input: {why}");
    out
}

/// `ours`, the answer to a set solved whole, made comparable with `recorded`, the recorded answer
/// to the same set when that was not solved whole: when it was cut short (`STATUS_INCOMPLETE`),
/// the members `recorded` did not solve are taken as recorded, and so are its status and message,
/// and the ranking keeps, in our order, the members `recorded` solved; when it was refused as
/// busy (`STATUS_BUSY`: nothing solved, nothing to compare), `recorded` itself. Borrowed as it is
/// otherwise, or when `recorded` holds another number of members.
pub(crate) fn cut_like<'a>(
    ours: &'a GripRecommendationSet,
    recorded: &GripRecommendationSet,
) -> Cow<'a, GripRecommendationSet> {
    if recorded.status == GripRecommendationSet::STATUS_BUSY {
        return Cow::Owned(recorded.clone());
    }
    if recorded.status != GripRecommendationSet::STATUS_INCOMPLETE
        || recorded.recommendations.len() != ours.recommendations.len()
    {
        return Cow::Borrowed(ours);
    }
    let solved =
        |i: usize| recorded.recommendations[i].status != GripRecommendation::STATUS_NOT_SOLVED;
    let mut out = ours.clone();
    for (i, r) in out.recommendations.iter_mut().enumerate() {
        if !solved(i) {
            *r = recorded.recommendations[i].clone();
        }
    }
    out.ranking.retain(|&i| solved(i as usize));
    out.status = recorded.status;
    out.message = recorded.message.clone();
    Cow::Owned(out)
}

/// A pool of `threads` threads to answer large sets on: the calling thread and `threads - 1`
/// started once, named `solver-1` and on; the reason when the system refuses them.
///
/// The calling thread is the pool's first worker (rayon's `use_current_thread`): when it asks the
/// pool for a set (`answer_set_on`) it solves its share instead of sleeping until the others are
/// done, and the answers it makes are freed on the thread that made them. So a pool of two on two
/// cores is one more thread, not two, and no thread waits to be woken at the end of a set.
/// Measured in one process on two cores (`cargo bench --bench sets`, the two kinds of pool taking
/// turns set by set): a set of 1,000 took 0.66 to 0.72 ms this way against 0.70 to 0.77 ms on two
/// started threads (four runs); with a set solved on one thread between the turns, so that the
/// started threads slept longer, 0.69 to 0.73 ms against 0.81 to 1.12 ms (eight rounds of 200).
///
/// A thread can be the first worker of one pool only, for its life: a second pool asked for on the
/// same thread is refused with that reason (the node asks once). Another thread may still use the
/// pool; its sets are then solved by the started threads alone.
pub fn solver_pool(threads: usize) -> Result<rayon::ThreadPool, PoolRefused> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .use_current_thread()
        .thread_name(|i| format!("solver-{i}"))
        .build()
        .map_err(|cause| PoolRefused { threads, cause })
}

/// The solver threads could not be started.
#[derive(Debug, thiserror::Error)]
#[error("cannot start {threads} solver threads: {cause}")]
pub struct PoolRefused {
    /// How many were asked for.
    pub threads: usize,
    /// Why not.
    #[source]
    pub cause: rayon::ThreadPoolBuildError,
}

/// The benchmark floor's answer to a set: as many empty recommendations as candidates (each with
/// its candidate's header and id), nothing solved, nothing ranked.
pub(crate) fn echo_set(set: &GraspCandidateSet) -> GripRecommendationSet {
    GripRecommendationSet {
        header: set.header.clone(),
        set_id: set.id.clone(),
        recommendations: set
            .candidates
            .iter()
            .map(|c| GripRecommendation {
                header: c.header.clone(),
                candidate_id: c.id.clone(),
                ..GripRecommendation::default()
            })
            .collect(),
        ..GripRecommendationSet::default()
    }
}

/// Whether `ranking` is sorted by the ranking key of `recommendations` as `ranked_by` names it
/// (`internal_force`, `finger_force` or `gripping_power`), within `tolerance` relative to the
/// larger magnitude (and 1), and with equal values in wrist rotation order; `None` when
/// `ranked_by` names no such field.
pub(crate) fn is_sorted_by(
    ranking: &[u32],
    recommendations: &[GripRecommendation],
    ranked_by: &str,
    tolerance: f64,
) -> Option<bool> {
    let key: fn(&GripRecommendation) -> f64 = match ranked_by {
        "internal_force" => |r| r.internal_force,
        "finger_force" => |r| r.finger_force,
        "gripping_power" => |r| r.gripping_power,
        _ => return None,
    };
    let close = |a: f64, b: f64| (a - b).abs() <= tolerance * 1f64.max(a.abs()).max(b.abs());
    let mut entries = Vec::with_capacity(ranking.len());
    for &i in ranking {
        entries.push(recommendations.get(i as usize)?);
    }
    Some(entries.windows(2).all(|w| {
        let (a, b) = (key(w[0]), key(w[1]));
        match a.partial_cmp(&b) {
            // A smaller value first is in order, however close: the ranking sorts the values
            // themselves, and only exact ties go to the wrist rotation.
            Some(Ordering::Less) => true,
            // A larger one only within the tolerance: solved again, two values may swap.
            Some(Ordering::Greater) => close(a, b),
            Some(Ordering::Equal) => {
                let (ra, rb) = (w[0].wrist_rotation.abs(), w[1].wrist_rotation.abs());
                ra <= rb || close(ra, rb)
            }
            None => false,
        }
    }))
}

/// A set's answer, of any set kind, as the node counts, logs and refuses it.
pub(crate) trait SetAnswer: Send + 'static {
    /// The set's id.
    fn set_id(&self) -> &CompactString;
    /// The set's status.
    fn status(&self) -> u8;
    /// Why, when the status is not OK.
    fn message(&self) -> &str;
    /// The members' recommendations, in order.
    fn members(&self) -> Vec<&GripRecommendation>;
    /// How many members are ranked, and by which field.
    fn ranked(&self) -> (usize, &str);
    /// The set refused whole: status 2 (`STATUS_INVALID_INPUT`) saying `why`, no members.
    fn refuse(&mut self, why: &str);
}

impl SetAnswer for GripRecommendationSet {
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
        self.recommendations.iter().collect()
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
    use crate::answer::runs::{answer_set, answer_set_on, answer_set_within, not_solved, RUN};
    use crate::answer::{Halt, Interrupt, PARALLEL_FROM};
    use crate::msg::paper_cases;

    fn set_of(candidates: Vec<GraspCandidate>) -> GraspCandidateSet {
        GraspCandidateSet {
            id: "s".into(),
            candidates,
            ..GraspCandidateSet::default()
        }
    }

    #[test]
    fn every_answer_of_a_set_is_the_single_answer_and_the_ranking_is_sorted() {
        let cases = paper_cases();
        let rules = Rules::default();
        let settings = Settings::default();
        let out = answer_set(&set_of(cases.clone()), &settings, &rules);
        assert_eq!(out.status, GripRecommendationSet::STATUS_OK);
        assert_eq!(out.recommendations.len(), 4);
        for (c, r) in cases.iter().zip(&out.recommendations) {
            assert_eq!(r, &answer_one(c, &settings, &rules));
        }
        assert_eq!(out.ranked_by, "internal_force");
        assert_eq!(out.ranking.len(), 4);
        let forces: Vec<f64> = out
            .ranking
            .iter()
            .map(|&i| out.recommendations[i as usize].internal_force)
            .collect();
        assert!(forces.windows(2).all(|w| w[0] <= w[1]), "{forces:?}");
        assert_eq!(
            is_sorted_by(&out.ranking, &out.recommendations, "internal_force", 0.0),
            Some(true)
        );
    }

    #[test]
    fn candidates_over_the_limit_get_status_3_with_every_field_and_leave_the_ranking() {
        let cases = paper_cases();
        let settings = Settings::default();
        let free = answer_set(&set_of(cases.clone()), &settings, &Rules::default());
        // A limit between the two smallest grip forces keeps exactly one candidate.
        let mut forces: Vec<f64> = free
            .recommendations
            .iter()
            .map(|r| r.internal_force)
            .collect();
        forces.sort_by(f64::total_cmp);
        assert!(forces[0] < forces[1], "{forces:?}");
        let limit = 0.5 * (forces[0] + forces[1]);
        let mut set = set_of(cases.clone());
        set.max_grip_force = limit;
        let out = answer_set(&set, &settings, &Rules::default());
        assert_eq!(out.ranking, [free.ranking[0]]);
        for (i, (limited, unlimited)) in out
            .recommendations
            .iter()
            .zip(&free.recommendations)
            .enumerate()
        {
            if i as u32 == free.ranking[0] {
                assert_eq!(limited, unlimited);
                continue;
            }
            assert_eq!(limited.status, GripRecommendation::STATUS_EXCEEDS_GRIPPER);
            assert!(
                limited.message.contains("max_grip_force")
                    && limited.message.contains("internal_force"),
                "{}",
                limited.message
            );
            let same = GripRecommendation {
                status: unlimited.status,
                message: unlimited.message.clone(),
                ..limited.clone()
            };
            assert_eq!(
                &same, unlimited,
                "every field but status and message is kept"
            );
        }
        // The node's limit applies when the set's is 0, and the set's wins when given.
        let node = Rules {
            max_grip_force: limit,
            ..Rules::default()
        };
        assert_eq!(
            answer_set(&set_of(cases.clone()), &settings, &node).ranking,
            out.ranking
        );
        set.max_grip_force = 1e9;
        assert_eq!(answer_set(&set, &settings, &node).ranking.len(), 4);
    }

    #[test]
    fn independent_fingers_rank_by_the_larger_push_and_objective_by_the_power() {
        let cases = paper_cases();
        let settings = Settings::default();
        for (rules, field) in [
            (
                Rules {
                    drive: GripperDrive::Independent,
                    ..Rules::default()
                },
                "finger_force",
            ),
            (
                Rules {
                    rank_by: RankBy::Objective,
                    ..Rules::default()
                },
                "gripping_power",
            ),
        ] {
            let out = answer_set(&set_of(cases.clone()), &settings, &rules);
            assert_eq!(out.ranked_by, field);
            assert_eq!(
                is_sorted_by(&out.ranking, &out.recommendations, field, 0.0),
                Some(true)
            );
            assert_eq!(out.ranking.len(), 4);
        }
        let r = &answer_set(&set_of(cases), &settings, &Rules::default()).recommendations[0];
        assert!(r.finger_force >= r.internal_force);
    }

    #[test]
    fn ties_go_to_the_smaller_wrist_rotation_then_the_lower_index() {
        let base = answer(&paper_cases()[0], &Settings::default());
        let with = |internal_force: f64, wrist_rotation: f64| GripRecommendation {
            internal_force,
            wrist_rotation,
            ..base.clone()
        };
        let recs = [
            with(2.0, 0.1),
            with(1.0, -0.5),
            with(1.0, 0.2),
            with(1.0, 0.2),
            GripRecommendation {
                status: GripRecommendation::STATUS_NO_FORCE_CLOSURE,
                ..with(0.0, 0.0)
            },
        ];
        assert_eq!(rank(&recs, &Rules::default()), [2, 3, 1, 0]);
        assert_eq!(
            is_sorted_by(&[1, 2, 3, 0], &recs, "internal_force", 1e-9),
            Some(false)
        );
        assert_eq!(is_sorted_by(&[2, 0], &recs, "nothing", 1e-9), None);
        // Values within the tolerance but not equal are ranked by value, not by wrist rotation
        // (0 N and 3e-14 N: two spatial grasps the node recorded so).
        let near = [with(0.0, 1.82), with(2.97e-14, 1.64)];
        assert_eq!(rank(&near, &Rules::default()), [0, 1]);
        assert_eq!(
            is_sorted_by(&[0, 1], &near, "internal_force", 1e-9),
            Some(true)
        );
        assert_eq!(
            is_sorted_by(&[1, 0], &near, "internal_force", 1e-9),
            Some(true),
            "solved again, close values may swap"
        );
    }

    #[test]
    fn bad_candidates_keep_their_status_and_the_rest_are_ranked() {
        let mut cases = paper_cases();
        cases[1].mass = f64::NAN;
        cases[2].friction_1 = 0.01;
        cases[2].friction_2 = 0.01;
        cases[2].normal_2.y = 0.9;
        let out = answer_set(&set_of(cases), &Settings::default(), &Rules::default());
        assert_eq!(out.status, GripRecommendationSet::STATUS_OK);
        assert_eq!(
            out.recommendations[1].status,
            GripRecommendation::STATUS_INVALID_INPUT
        );
        assert_eq!(
            out.recommendations[2].status,
            GripRecommendation::STATUS_NO_FORCE_CLOSURE
        );
        let mut ranked = out.ranking.clone();
        ranked.sort_unstable();
        assert_eq!(ranked, [0, 3]);
    }

    /// Candidates of every kind the set path answers, varied so that no two are alike: planar
    /// exact, planar with tolerances (robust), spatial in and off the x-y plane, with a mass
    /// tolerance, with a centre-of-mass box, behind a tangent, without force closure, refused
    /// for a field and for the model.
    fn every_kind(n: usize) -> Vec<GraspCandidate> {
        let cases = paper_cases();
        (0..n)
            .map(|i| {
                let mut c = cases[i % 4].clone();
                c.id = format!("c{i}").into();
                let u = (i as f64 * 0.618_033_988_749_895).fract();
                c.center_of_mass.x += 0.2 * (u - 0.5);
                c.center_of_mass.y -= 0.3 * u;
                match (i / 4) % 9 {
                    0 => {}
                    1 => c.center_of_mass_tolerance.x = 0.01,
                    2 => {
                        c.model = GraspCandidate::MODEL_SPATIAL;
                        c.center_of_mass.z = 0.1 * u;
                    }
                    3 => {
                        c.model = GraspCandidate::MODEL_SPATIAL;
                        c.mass_tolerance = 0.3 * c.mass;
                    }
                    4 => {
                        c.model = GraspCandidate::MODEL_SPATIAL;
                        c.center_of_mass_tolerance.y = 0.01;
                    }
                    5 => c.center_of_mass.y = 5.0, // behind the tangents, or no closure
                    6 => c.friction_1 = 0.05,      // no force closure
                    7 => c.mass = -1.0,            // refused: the mass
                    _ => c.model = 7,              // refused: the model
                }
                c
            })
            .collect()
    }

    /// The set path answers through the solver's batch path in runs (`answer_run`): every
    /// member's answer is still `answer_one`'s bit for bit, over runs that mix every kind of
    /// candidate, with the node's tolerances and a grip-force limit, on one thread and on pools.
    #[test]
    fn runs_through_the_batch_path_answer_as_one_by_one() {
        let set = set_of(every_kind(5 * RUN + 3));
        let settings = Settings::default();
        // A limit half the held candidates exceed (status 3), so that the limit is checked on
        // answers of the batch path as well.
        let mut forces: Vec<f64> = set
            .candidates
            .iter()
            .map(|c| answer_one(c, &settings, &Rules::default()))
            .filter(|r| r.status == GripRecommendation::STATUS_OK)
            .map(|r| r.internal_force)
            .collect();
        forces.sort_by(f64::total_cmp);
        let with_tolerances = Rules {
            tolerances: DefaultTolerances {
                center_of_mass: [0.0; 3],
                mass: 0.05,
            },
            max_grip_force: forces[forces.len() / 2],
            ..Rules::default()
        };
        for rules in [Rules::default(), with_tolerances] {
            let one: Vec<String> = set
                .candidates
                .iter()
                .map(|c| format!("{:?}", answer_one(c, &settings, &rules)))
                .collect();
            let statuses: std::collections::BTreeSet<u8> = set
                .candidates
                .iter()
                .map(|c| answer_one(c, &settings, &rules).status)
                .collect();
            assert!(statuses.len() >= 3, "{statuses:?}");
            let limited = rules.max_grip_force > 0.0;
            assert_eq!(
                statuses.contains(&GripRecommendation::STATUS_EXCEEDS_GRIPPER),
                limited
            );
            for threads in [1, 2, 3] {
                let got = std::thread::scope(|s| {
                    s.spawn(|| {
                        let pool = solver_pool(threads).expect("threads");
                        answer_set_on(&set, &settings, &rules, Some(&pool))
                    })
                    .join()
                    .expect("no panic")
                });
                assert_eq!(got.recommendations.len(), one.len());
                for (i, (r, want)) in got.recommendations.iter().zip(&one).enumerate() {
                    assert_eq!(&format!("{r:?}"), want, "{threads} threads: candidate {i}");
                }
            }
            // The front door's many at once (what the Python module calls), on this thread.
            let poses = super::super::PoseAnswerer::new(
                crate::geometry::ClosingAxis::Y,
                Default::default(),
            );
            let with = super::super::Answering::new(settings, rules, poses);
            let many = with.answer_many::<crate::kind::Candidates>(&set.candidates);
            assert_eq!(many.len(), one.len());
            for (i, (r, want)) in many.iter().zip(&one).enumerate() {
                assert_eq!(&format!("{r:?}"), want, "answer_many: candidate {i}");
            }
        }
    }

    #[test]
    fn threads_give_the_same_answer() {
        let mut cases = paper_cases();
        cases[1].mass = f64::NAN;
        let many: Vec<GraspCandidate> = (0..3 * PARALLEL_FROM + 7)
            .map(|i| {
                let mut c = cases[i % 4].clone();
                c.id = format!("c{i}").into();
                c
            })
            .collect();
        let set = set_of(many);
        let one = answer_set(&set, &Settings::default(), &Rules::default());
        for threads in [1, 2, 3, 8] {
            // Each pool takes its own thread as its first worker (`solver_pool`).
            let on = std::thread::scope(|s| {
                s.spawn(|| {
                    let pool = solver_pool(threads).expect("threads");
                    answer_set_on(&set, &Settings::default(), &Rules::default(), Some(&pool))
                })
                .join()
                .expect("no panic")
            });
            assert_eq!(format!("{on:?}"), format!("{one:?}"), "{threads} threads");
        }
        // The same pool from another thread: solved by the started threads alone, the same answer.
        let pool = std::thread::scope(|s| s.spawn(|| solver_pool(3)).join().expect("no panic"));
        let on = answer_set_on(
            &set,
            &Settings::default(),
            &Rules::default(),
            pool.ok().as_ref(),
        );
        assert_eq!(format!("{on:?}"), format!("{one:?}"), "from another thread");
        // A thread is the first worker of one pool only.
        std::thread::scope(|s| {
            s.spawn(|| {
                let _first = solver_pool(2).expect("threads");
                let second = solver_pool(2).expect_err("a second pool on the same thread");
                assert!(
                    second.to_string().contains("cannot start 2 solver threads"),
                    "{second}"
                );
            });
        });
    }

    #[test]
    fn total_order_is_total_cmp() {
        let xs = [
            f64::NEG_INFINITY,
            -1e300,
            -1.0,
            -f64::MIN_POSITIVE,
            -5e-324,
            -0.0,
            0.0,
            5e-324,
            1.0,
            1e300,
            f64::INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for a in xs {
            for b in xs {
                assert_eq!(
                    total_order(a).cmp(&total_order(b)),
                    a.total_cmp(&b),
                    "{a} against {b}"
                );
            }
        }
    }

    /// A set whose solving is stopped answers the members left with status 4 and itself with
    /// STATUS_INCOMPLETE, saying why and how many were solved; with no raise, the same answer as
    /// answer_set_on, bit for bit.
    #[test]
    fn an_interrupted_set_answers_the_rest_not_solved() {
        let cases = paper_cases();
        let set = set_of(cases.clone());
        let (settings, rules) = (Settings::default(), Rules::default());
        let calm = Interrupt::default();
        let whole = answer_set_within(&set, &settings, &rules, None, &calm, 10.0);
        assert_eq!(
            format!("{whole:?}"),
            format!("{:?}", answer_set(&set, &settings, &rules))
        );
        let stop = Interrupt::default();
        stop.raise(Halt::OutOfTime);
        let out = answer_set_within(&set, &settings, &rules, None, &stop, 2.5);
        assert_eq!(out.status, GripRecommendationSet::STATUS_INCOMPLETE);
        assert!(
            out.message
                .contains("max_set_time (2.5 s) ran out with 0 of 4 candidates solved"),
            "{}",
            out.message
        );
        assert!(out.ranking.is_empty());
        for (c, r) in cases.iter().zip(&out.recommendations) {
            assert_eq!(r.status, GripRecommendation::STATUS_NOT_SOLVED);
            assert_eq!((&r.candidate_id, &r.header), (&c.id, &c.header));
            assert!(r.message.contains("max_set_time"), "{}", r.message);
        }
        // Stopping outlasts a lowered time, and wins over it.
        stop.raise(Halt::Stopping);
        stop.lower_time();
        assert_eq!(stop.halt(), Some(Halt::Stopping));
        let out = answer_set_within(&set, &settings, &rules, None, &stop, 2.5);
        assert!(
            out.message.contains("the node was stopping"),
            "{}",
            out.message
        );
        // A set refused whole keeps its refusal.
        let small = Rules {
            max_set_size: 3,
            ..rules
        };
        let out = answer_set_within(&set, &settings, &small, None, &stop, 2.5);
        assert_eq!(out.status, GripRecommendationSet::STATUS_TOO_LARGE);
    }

    /// Raised while the set is solved, on one thread and on a pool: the members solved before are
    /// the whole set's answers, the rest status 4, and the ranking ranks the solved ones.
    #[test]
    fn a_set_stopped_midway_keeps_what_was_solved() {
        // Uncertain centres of mass: the robust solver, tens of microseconds a candidate, so that
        // the raise after 30 ms falls inside the set on a busy machine too.
        let cases: Vec<GraspCandidate> = paper_cases()
            .into_iter()
            .map(|mut c| {
                c.center_of_mass_tolerance.x = 0.01;
                c
            })
            .collect();
        let set = set_of((0..100_000).map(|i| cases[i % 4].clone()).collect());
        let (settings, rules) = (
            Settings::default(),
            Rules {
                max_set_size: 1_000_000,
                ..Rules::default()
            },
        );
        let whole: Vec<GripRecommendation> = cases
            .iter()
            .map(|c| answer_one(c, &settings, &rules))
            .collect();
        for threads in [1, 2] {
            let interrupt = Interrupt::default();
            let out = std::thread::scope(|s| {
                let solving = s.spawn(|| {
                    let pool = solver_pool(threads).expect("threads");
                    answer_set_within(&set, &settings, &rules, Some(&pool), &interrupt, 0.03)
                });
                std::thread::sleep(std::time::Duration::from_millis(30));
                interrupt.raise(Halt::OutOfTime);
                solving.join().expect("no panic")
            });
            assert_eq!(out.status, GripRecommendationSet::STATUS_INCOMPLETE);
            let unsolved =
                |i: &usize| out.recommendations[*i].status == GripRecommendation::STATUS_NOT_SOLVED;
            let solved: Vec<usize> = (0..set.candidates.len()).filter(|i| !unsolved(i)).collect();
            assert!(
                !solved.is_empty() && solved.len() < set.candidates.len(),
                "{threads} threads: {} solved",
                solved.len()
            );
            for &i in &solved {
                assert_eq!(out.recommendations[i], whole[i % 4]);
            }
            let message = format!("with {} of 100000 candidates solved", solved.len());
            assert!(out.message.contains(&message), "{}", out.message);
            assert_eq!(out.ranking, rank(&out.recommendations, &rules));
            assert!(
                !out.ranking.is_empty() && !out.ranking.iter().any(|&i| unsolved(&(i as usize)))
            );
        }
    }

    #[test]
    fn a_busy_answer_refuses_at_once_unless_the_set_has_its_own_refusal() {
        let rules = Rules::default();
        let out = busy(&set_of(paper_cases()), &rules, 16);
        assert_eq!(out.status, GripRecommendationSet::STATUS_BUSY);
        assert!(out.recommendations.is_empty() && out.ranking.is_empty());
        assert!(
            out.message.contains("16 sets already wait") && out.message.contains("max_queued_sets"),
            "{}",
            out.message
        );
        let mut bad = set_of(paper_cases());
        bad.max_grip_force = -1.0;
        assert_eq!(
            busy(&bad, &rules, 16).status,
            GripRecommendationSet::STATUS_INVALID_INPUT
        );
    }

    /// Replay compares a set solved whole with a recorded answer that was cut: the members the
    /// recording did not solve are taken as recorded, the ranking keeps the solved ones.
    #[test]
    fn cut_like_takes_what_the_recording_left_unsolved_as_recorded() {
        let set = set_of(paper_cases());
        let (settings, rules) = (Settings::default(), Rules::default());
        let ours = answer_set(&set, &settings, &rules);
        assert!(matches!(cut_like(&ours, &ours), Cow::Borrowed(_)));
        let mut recorded = ours.clone();
        recorded.status = GripRecommendationSet::STATUS_INCOMPLETE;
        recorded.message = "incomplete: the node was stopping".into();
        for i in [1, 3] {
            recorded.recommendations[i] = not_solved(&set.candidates[i], Halt::Stopping);
        }
        recorded.ranking.retain(|&i| i != 1 && i != 3);
        let like = cut_like(&ours, &recorded);
        assert_eq!(*like, recorded);
        // A member solved differently still differs.
        recorded.recommendations[0].internal_force += 1.0;
        assert_ne!(*cut_like(&ours, &recorded), recorded);
        // A set refused as busy was not solved: nothing to compare.
        let refused = busy(&set, &rules, 0);
        assert_eq!(*cut_like(&ours, &refused), refused);
    }

    #[test]
    fn an_empty_set_gets_an_empty_answer() {
        let out = answer_set(&set_of(Vec::new()), &Settings::default(), &Rules::default());
        assert_eq!(out.status, GripRecommendationSet::STATUS_OK);
        assert!(out.recommendations.is_empty() && out.ranking.is_empty());
        assert_eq!(
            (out.set_id.as_str(), out.ranked_by.as_str()),
            ("s", "internal_force")
        );
    }

    /// A million candidates are refused at once, before anything is solved.
    #[test]
    fn a_million_candidates_are_refused_with_a_status() {
        let set = set_of(vec![paper_cases().remove(0); 1_000_000]);
        let started = std::time::Instant::now();
        let out = answer_set(&set, &Settings::default(), &Rules::default());
        assert!(
            started.elapsed().as_secs_f64() < 0.5,
            "refusing took {:?}",
            started.elapsed()
        );
        assert_eq!(out.status, GripRecommendationSet::STATUS_TOO_LARGE);
        assert!(out.recommendations.is_empty());
        assert!(
            out.message.contains("1000000 candidates")
                && out.message.contains("max_set_size 10000"),
            "{}",
            out.message
        );
        let small = Rules {
            max_set_size: 3,
            ..Rules::default()
        };
        let out = answer_set(&set_of(paper_cases()), &Settings::default(), &small);
        assert_eq!(out.status, GripRecommendationSet::STATUS_TOO_LARGE);
        let three = set_of(paper_cases()[..3].to_vec());
        assert_eq!(
            answer_set(&three, &Settings::default(), &small)
                .recommendations
                .len(),
            3
        );
    }

    #[test]
    fn a_set_with_bad_fields_of_its_own_is_refused() {
        for limit in [-1.0, f64::NAN, f64::INFINITY] {
            let mut set = set_of(paper_cases());
            set.max_grip_force = limit;
            let out = answer_set(&set, &Settings::default(), &Rules::default());
            assert_eq!(
                out.status,
                GripRecommendationSet::STATUS_INVALID_INPUT,
                "{limit}"
            );
            assert!(out.message.contains("max_grip_force"), "{}", out.message);
        }
        let mut set = set_of(paper_cases());
        set.id = "x".repeat(2000).into();
        let out = answer_set(&set, &Settings::default(), &Rules::default());
        assert_eq!(out.status, GripRecommendationSet::STATUS_INVALID_INPUT);
        assert_eq!(out.set_id.len(), MAX_TEXT_BYTES);
    }

    #[test]
    fn single_candidates_get_status_3_when_the_limit_is_set() {
        let c = &paper_cases()[0];
        let free = answer(c, &Settings::default());
        let tight = Rules {
            max_grip_force: 0.5 * free.internal_force,
            ..Rules::default()
        };
        assert_eq!(
            answer_one(c, &Settings::default(), &tight).status,
            GripRecommendation::STATUS_EXCEEDS_GRIPPER
        );
        assert_eq!(answer_one(c, &Settings::default(), &Rules::default()), free);
    }

    #[test]
    fn the_echo_has_one_empty_answer_per_candidate() {
        let set = set_of(paper_cases());
        let echo = echo_set(&set);
        assert_eq!(echo.recommendations.len(), 4);
        assert_eq!(echo.recommendations[2].candidate_id, set.candidates[2].id);
        assert!(echo.ranking.is_empty());
    }

    /// The node's tolerances fill a candidate's zero ones; a candidate's own non-zero wins, per
    /// field; all zero leaves the candidate borrowed (bit-identical answers).
    #[test]
    fn default_tolerances_apply_where_the_candidate_gives_none() {
        let c = paper_cases().swap_remove(2);
        let none = DefaultTolerances::default();
        assert!(matches!(none.apply(&c), Cow::Borrowed(_)));
        let node = DefaultTolerances {
            center_of_mass: [0.002, 0.001, 0.0],
            mass: 0.02,
        };
        let filled = node.apply(&c);
        assert_eq!(filled.center_of_mass_tolerance.x, 0.002);
        assert_eq!(filled.center_of_mass_tolerance.y, 0.001);
        assert_eq!(filled.mass_tolerance, 0.02);
        let mut own = c.clone();
        own.center_of_mass_tolerance.x = 0.003;
        let kept = node.apply(&own);
        assert_eq!(
            (
                kept.center_of_mass_tolerance.x,
                kept.center_of_mass_tolerance.y
            ),
            (0.003, 0.0)
        );
        assert_eq!(kept.mass_tolerance, 0.02);
        let rules = Rules {
            tolerances: node,
            ..Rules::default()
        };
        assert_eq!(
            answer_one(&c, &Settings::default(), &rules),
            answer(&filled, &Settings::default())
        );
        assert_ne!(
            answer_one(&c, &Settings::default(), &rules).gripping_power,
            answer(&c, &Settings::default()).gripping_power
        );
    }
}
