//! How a set, or many candidates at once, is answered (the rules and the ranking are
//! `sets.rs`'s): in order, in runs through the solver's batch path (each answer the one
//! [`answer_one`] gives alone, bit for bit), on the threads of a pool for a large set, and
//! stopped between two runs once an [`Interrupt`] is raised.

use super::sets::{answer_one, apply_limit, empty_answer, rank, refusal, Rules};
use crate::msg::{
    clip, CompactString, GraspCandidate, GraspCandidateSet, GripRecommendation,
    GripRecommendationSet,
};
use crate::solver::Settings;
use std::borrow::Cow;
use std::sync::atomic::{AtomicU8, Ordering as AtomicOrdering};

/// The answer to a set: each candidate as [`answer_one`] answers it, with the set's own
/// `max_grip_force` when above 0, and the ranking. A set refused as a whole (too large, or with
/// bad fields of its own) gets its status and no recommendations.
pub(crate) fn answer_set(
    set: &GraspCandidateSet,
    settings: &Settings,
    rules: &Rules,
) -> GripRecommendationSet {
    answer_set_on(set, settings, rules, None)
}

/// Sets smaller than this are answered in the calling thread whatever the pool: handing work to
/// another thread and waking it costs about what solving a few dozen candidates does.
pub(crate) const PARALLEL_FROM: usize = 128;

/// [`answer_set`] with the candidates shared among the threads of `pool` when there is one: the
/// same answer, sooner on a machine with idle cores. The node keeps one pool for its life
/// ([`solver_pool`], parameter `solver_threads`); a thread started for each set would begin with
/// an empty heap, and the pages it faulted in cost more than its share of the solving.
/// The library's [`answer_set`] stays on the calling thread.
pub(crate) fn answer_set_on(
    set: &GraspCandidateSet,
    settings: &Settings,
    rules: &Rules,
    pool: Option<&rayon::ThreadPool>,
) -> GripRecommendationSet {
    answer_set_inner(set, settings, rules, pool, None)
}

/// [`answer_set_on`], stopped between two candidates once `interrupt` is raised: the candidates
/// not solved by then are answered with `STATUS_NOT_SOLVED` (header and id only, and a message
/// that says why), the set with `STATUS_INCOMPLETE` and a message that says why and how many were
/// solved (`max_set_time`, s, is the budget the message names), and the ranking ranks the solved
/// ones. With no raise before the last candidate, the answer is [`answer_set_on`]'s.
///
/// On a pool the solved candidates need not be the first ones: each thread stops where it is.
/// A candidate is never stopped in the middle: one that takes long holds its thread until done.
pub(crate) fn answer_set_within(
    set: &GraspCandidateSet,
    settings: &Settings,
    rules: &Rules,
    pool: Option<&rayon::ThreadPool>,
    interrupt: &Interrupt,
    max_set_time: f64,
) -> GripRecommendationSet {
    let mut out = answer_set_inner(set, settings, rules, pool, Some(interrupt));
    let Some(halt) = interrupt.halt() else {
        return out;
    };
    let n = out.recommendations.len();
    let unsolved = out
        .recommendations
        .iter()
        .filter(|r| r.status == GripRecommendation::STATUS_NOT_SOLVED)
        .count();
    if out.status != GripRecommendationSet::STATUS_OK || unsolved == 0 {
        return out;
    }
    let solved = n - unsolved;
    out.status = GripRecommendationSet::STATUS_INCOMPLETE;
    out.message = match halt {
        Halt::OutOfTime => compact_str::format_compact!(
            "incomplete: max_set_time ({max_set_time} s) ran out with {solved} of {n} candidates \
             solved; the other {unsolved} have status 4 (not solved): raise max_set_time, or send \
             smaller sets"
        ),
        Halt::Stopping => compact_str::format_compact!(
            "incomplete: the node was stopping, with {solved} of {n} candidates solved; the other \
             {unsolved} have status 4 (not solved)"
        ),
    };
    out
}

/// The answer to a set, stopped by `interrupt` when there is one and it is raised.
fn answer_set_inner(
    set: &GraspCandidateSet,
    settings: &Settings,
    rules: &Rules,
    pool: Option<&rayon::ThreadPool>,
    interrupt: Option<&Interrupt>,
) -> GripRecommendationSet {
    let mut out = empty_answer(set, rules);
    if let Some((status, message)) = refusal(set, rules) {
        out.status = status;
        out.message = message.into();
        return out;
    }
    let rules = Rules {
        max_grip_force: if set.max_grip_force > 0.0 {
            set.max_grip_force
        } else {
            rules.max_grip_force
        },
        ..*rules
    };
    out.recommendations = answer_all(&set.candidates, settings, &rules, pool, interrupt);
    out.ranking = rank(&out.recommendations, &rules);
    out
}

/// Every candidate answered in order on the calling thread, each [`answer_one`]'s answer bit for
/// bit, through the solver's batch path in runs ([`answer_run`]).
pub(crate) fn answer_each(
    candidates: &[GraspCandidate],
    settings: &Settings,
    rules: &Rules,
) -> Vec<GripRecommendation> {
    answer_all(candidates, settings, rules, None, None)
}

/// Every candidate answered in order, on the threads of `pool` for a large set, in runs of
/// [`RUN`] ([`answer_run`]); once `interrupt` is raised, each run left, and each candidate left
/// that a run answers alone, is answered [`not_solved`].
pub(crate) fn answer_all(
    candidates: &[GraspCandidate],
    settings: &Settings,
    rules: &Rules,
    pool: Option<&rayon::ThreadPool>,
    interrupt: Option<&Interrupt>,
) -> Vec<GripRecommendation> {
    let halt = || interrupt.and_then(Interrupt::halt);
    let mut out = Vec::with_capacity(candidates.len());
    match pool {
        Some(pool) if pool.current_num_threads() > 1 && candidates.len() >= PARALLEL_FROM => {
            use rayon::prelude::*;
            // Each run's answers in a vector of their own, moved into place after the last: a
            // vector of placeholders to write into would be made before the first candidate is
            // solved, and a set stopped early would pay for all of them.
            let runs: Vec<Vec<GripRecommendation>> = pool.install(|| {
                candidates
                    .par_chunks(RUN)
                    .with_min_len(PARALLEL_FROM / 2 / RUN)
                    .map(|run| {
                        let mut out = Vec::with_capacity(run.len());
                        answer_run(run, settings, rules, &halt, &mut out);
                        out
                    })
                    .collect()
            });
            for run in runs {
                out.extend(run);
            }
        }
        _ => {
            for run in candidates.chunks(RUN) {
                answer_run(run, settings, rules, &halt, &mut out);
            }
        }
    }
    out
}

/// How many candidates of a set go to the solver's batch path in one call ([`answer_run`]):
/// enough that the storage one answer hands to the next (`solver::batch`) is used again, few
/// enough that a set stopped by its interrupt (`max_set_time`) answers at most a run's exact
/// candidates, about 30 µs, after the raise.
pub(crate) const RUN: usize = 32;

/// How a member of a run is answered ([`answer_run`]): its candidate after the node's
/// tolerances, and which path.
enum Member<'a> {
    /// Through the solver's batch path, planar.
    Planar(Cow<'a, GraspCandidate>),
    /// Through the solver's batch path, spatial, with the factor on its forces.
    Spatial(Cow<'a, GraspCandidate>, Option<f64>),
    /// By [`answer_one`] alone.
    Alone,
}

/// Appends `answer_one(c, settings, rules)` for every `c` of `run` to `out`, in order, the same
/// answers bit for bit: the exact planar candidates and the spatial ones without a
/// centre-of-mass box (after the node's tolerances) through the solver's batch path on this
/// thread (`solver::batch::planar_with`, `spatial_with`; `candidate::for_batch`), the others
/// (the robust solvers, refusals) one by one. Once `halt` says so, nothing more is solved: the
/// run whole, or each candidate answered alone, is [`not_solved`].
fn answer_run(
    run: &[GraspCandidate],
    settings: &Settings,
    rules: &Rules,
    halt: &(dyn Fn() -> Option<Halt> + Sync),
    out: &mut Vec<GripRecommendation>,
) {
    use super::candidate::{for_batch, planar_reply_of, spatial_reply_of, ForBatch};
    use crate::solver::batch::{self, Threads};
    if let Some(h) = halt() {
        out.extend(run.iter().map(|c| not_solved(c, h)));
        return;
    }
    let (mut planar, mut spatial) = (Vec::new(), Vec::new());
    let members: Vec<Member<'_>> = run
        .iter()
        .map(|c| {
            let m = rules.tolerances.apply(c);
            match for_batch(&m) {
                Some(ForBatch::Planar(p)) => {
                    planar.push(p);
                    Member::Planar(m)
                }
                Some(ForBatch::Spatial(p, factor)) => {
                    spatial.push(p);
                    Member::Spatial(m, factor)
                }
                None => Member::Alone,
            }
        })
        .collect();
    let mut planar_answers = Vec::with_capacity(planar.len());
    batch::planar_with(&planar, settings, Threads::ONE, &mut planar_answers);
    let mut spatial_answers = Vec::with_capacity(spatial.len());
    batch::spatial_with(&spatial, settings, Threads::ONE, &mut spatial_answers);
    let (mut planar_answers, mut spatial_answers) =
        (planar_answers.into_iter(), spatial_answers.into_iter());
    for (c, member) in run.iter().zip(members) {
        // One answer of each batch per member of its kind, in order: the batches are as long as
        // their kind's members.
        let solved = match member {
            Member::Planar(m) => planar_answers
                .next()
                .map(|solved| planar_reply_of(&m, solved, settings)),
            Member::Spatial(m, factor) => spatial_answers
                .next()
                .map(|solved| spatial_reply_of(&m, solved, factor, settings)),
            Member::Alone => None,
        };
        let Some(mut reply) = solved else {
            // Alone (a batch never runs short: the fallback is answer_one's answer too).
            out.push(match halt() {
                Some(h) => not_solved(c, h),
                None => answer_one(c, settings, rules),
            });
            continue;
        };
        apply_limit(&mut reply, rules.drive, rules.max_grip_force);
        out.push(reply);
    }
}

/// Why the solving of a set stopped before its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Halt {
    /// Its time (parameter `max_set_time`) ran out.
    OutOfTime,
    /// The node is stopping.
    Stopping,
}

/// A flag that another thread raises to stop the solving of a set between two candidates
/// (`answer_set_within`): the node's clock when a set's time runs out, its shutdown. A raised
/// [`Halt::Stopping`] stays raised; [`Halt::OutOfTime`] is lowered for the next set with
/// `Interrupt::lower_time`.
#[derive(Debug, Default)]
pub struct Interrupt(AtomicU8);

impl Interrupt {
    const OUT_OF_TIME: u8 = 1;
    const STOPPING: u8 = 2;

    /// Raises `halt`.
    pub fn raise(&self, halt: Halt) {
        let bit = match halt {
            Halt::OutOfTime => Self::OUT_OF_TIME,
            Halt::Stopping => Self::STOPPING,
        };
        self.0.fetch_or(bit, AtomicOrdering::SeqCst);
    }

    /// Lowers [`Halt::OutOfTime`] (a stop stays raised).
    pub(crate) fn lower_time(&self) {
        self.0.fetch_and(!Self::OUT_OF_TIME, AtomicOrdering::SeqCst);
    }

    /// What is raised: [`Halt::Stopping`] before [`Halt::OutOfTime`].
    pub(crate) fn halt(&self) -> Option<Halt> {
        let bits = self.0.load(AtomicOrdering::Relaxed);
        if bits & Self::STOPPING != 0 {
            Some(Halt::Stopping)
        } else if bits & Self::OUT_OF_TIME != 0 {
            Some(Halt::OutOfTime)
        } else {
            None
        }
    }
}

/// The answer to a member of a set that was not solved: its header and id, status 4
/// (`STATUS_NOT_SOLVED`), and why.
pub(crate) fn not_solved(c: &GraspCandidate, halt: Halt) -> GripRecommendation {
    let mut header = c.header.clone();
    header.frame_id = clip(&header.frame_id).into();
    GripRecommendation {
        header,
        candidate_id: clip(&c.id).into(),
        status: GripRecommendation::STATUS_NOT_SOLVED,
        message: CompactString::const_new(match halt {
            Halt::OutOfTime => "not solved: the set's max_set_time ran out",
            Halt::Stopping => "not solved: the node was stopping",
        }),
        ..GripRecommendation::default()
    }
}
