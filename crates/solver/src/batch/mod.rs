//! Many candidates in one call: [`planar`] and [`spatial`] answer a slice of grasps with the
//! same settings, in order, each answer equal bit for bit, every field, to what
//! [`crate::planar::solve`] or [`crate::spatial::solve`] gives for that grasp alone (the only
//! difference is the type: the recommendation is not boxed, [`PlanarAnswer`], [`SpatialAnswer`]).
//! Every objective and range is answered, refusals included.
//!
//! # Where one grasp's time goes
//! `perf record` of the single path in `benches/batch.rs` (norm2 from above, 1,000 random planar
//! grasps with force closure, release build), shares of its time:
//!
//! | share | what |
//! |---|---|
//! | 28 % | the C library's `sin_cos` and `atan2`: the ends and minima of the envelope's pieces (`Angle::new`, `sinusoid.rs`), the stationary points of the quadratic forms (`QuadForm::minima_between`, `sinusoid.rs`), the current gravity angle and the ranges (`planar/frame.rs`, `planar/paper.rs`) |
//! | 17 % | force closure, the closed forms and the walk of the envelope into pieces (`Analysis::new`, `planar/analysis.rs`, with `planar/paper.rs` inlined): data-dependent branches, two to six pieces a grasp |
//! | 9 % | the SIMD `atan2` of the ten crossings of the bounds (`rising_zeros`, `sinusoid.rs`), four a call |
//! | 22 % | the recommendation: the candidate points, the objective there, the local minima and the labels (`recommend`, `evaluate_at` in `planar/analysis.rs`; `planar/curve.rs`) |
//! | 12 % | validation and the map into the paper frame (`planar/frame.rs`) |
//! | 6 % | allocating, copying and freeing the answer (its box, its list of minima, the pieces) |
//!
//! # Layout, and why
//! Little of that is both vectorisable and exact. A vector `sin_cos` or `atan2` across grasps
//! gives other bits than the C library's (the `wide` crate's `atan2` is within 4.4e-16 rad of
//! it, `sinusoid.rs`), and the answer is made of decisions on those values (which bound is on
//! top, which candidate point is lowest, what ties, which label an angle gets): an angle one
//! rounding away can change a label or a tie-break, which is not the same answer, and a
//! gravity angle near zero has no relative error to speak of. The walk of the envelope is a short
//! data-dependent sequence per grasp, with nothing to lay side by side across grasps. Packing the
//! ten crossings of every grasp into full four-lane `atan2` calls (12 lanes a grasp today, 10
//! then) would save at most a sixth of its 9 %. So the batch keeps each grasp's arithmetic the
//! single path's (the same functions, called in the same order: the answers are equal bit for
//! bit) and takes its gain where it is exact:
//! - **Nothing allocated per grasp but the answer's list of minima**: the storage of the
//!   envelope's pieces is handed from grasp to grasp (`Analysis::reusing`,
//!   `planar/analysis.rs`), and the answer goes unboxed into the caller's vector
//!   (`batch/planar.rs`, `spatial/batch.rs`: the steps of `planar::solve` and `spatial::solve`,
//!   with the same reduction to the plane, `spatial/plane.rs`; on the contact axis the single
//!   path's search, `spatial/on_axis.rs`).
//! - **Every core for a large batch**: the grasps are independent, so the calling thread and
//!   helper threads started once (`batch/pool.rs`, which says why not threads per batch) each
//!   take the next piece of 32 grasps not yet taken. The calling thread never waits long for a
//!   helper the machine does not schedule: it answers that piece itself. Helpers join only for
//!   [`MIN_PER_THREAD`] grasps a thread or more (handing work over costs microseconds), not at
//!   all under [`Threads::ONE`] (for a caller with a pool of its own), and not for a while after
//!   a batch in which they did not run beside the caller (`batch/pool.rs`, *Backing off*): on a
//!   machine whose cores are busy with other work a woken helper often runs on the caller's own
//!   core first (`docs/performance.md`).
//!
//! The mathematics is all the single path's: `planar/frame.rs` (validation, paper frame),
//! `planar/paper.rs` (closed forms, force closure), `planar/analysis.rs` and `planar/curve.rs`
//! (envelope, objective, minima), `spatial/plane.rs` and `spatial/on_axis.rs` (the reduction to
//! the grasp plane); `docs/theory.md` derives it.

mod planar;
mod pool;

pub use crate::spatial::batch::SpatialAnswer;
pub use planar::PlanarAnswer;

use crate::{planar as planar_solver, spatial as spatial_solver, InvalidInput, Settings};
use std::num::NonZeroUsize;

/// The fewest grasps a thread of the batch is started for (see the module docs): below
/// `2 × MIN_PER_THREAD` grasps the batch runs on the calling thread alone.
pub const MIN_PER_THREAD: usize = 256;

/// How many threads a batch may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threads {
    /// As many as [`std::thread::available_parallelism`] says, when the batch is large enough.
    /// The helper threads (one fewer than that) start with the first such batch and then wait
    /// for work as long as the process lives. They pay only when a core is free: on a machine
    /// whose cores are busy with other work a woken helper may run on the caller's core first,
    /// and the batch then takes as long as on [`Threads::ONE`] or longer; the next batches then
    /// leave the helpers out for a while (`batch/pool.rs`, `docs/performance.md`).
    Available,
    /// At most this many (1: the calling thread only, for a caller that has its own pool).
    AtMost(NonZeroUsize),
}

impl Threads {
    /// The calling thread only.
    pub const ONE: Threads = Threads::AtMost(NonZeroUsize::MIN);

    /// How many threads a batch of `n` grasps runs on: at most the limit, and each with at
    /// least [`MIN_PER_THREAD`] grasps.
    pub fn for_batch(self, n: usize) -> usize {
        let limit = match self {
            Threads::Available => pool::cores(),
            Threads::AtMost(k) => k.get(),
        };
        (n / MIN_PER_THREAD).clamp(1, limit.max(1))
    }
}

/// Answers every planar candidate with `settings`, appending the answers to `out` in the
/// candidates' order (what was in `out` stays). Each answer equals
/// `planar::solve(candidate, settings)`; a large batch runs on the cores [`Threads::Available`]
/// allows.
///
/// # Example
/// The paper's four cases in one call: the same answers as one by one.
/// ```
/// use grasp_orient_solver::{batch, planar, table_1::table_1, Settings};
///
/// let grasps: Vec<_> = ['a', 'b', 'c', 'd'].map(table_1).into();
/// let mut answers = Vec::new();
/// batch::planar(&grasps, &Settings::default(), &mut answers);
/// for (g, a) in grasps.iter().zip(&answers) {
///     let Ok(planar::Verdict::Recommended(one)) = planar::solve(g, &Settings::default()) else {
///         panic!("Table 1's cases have force closure");
///     };
///     assert_eq!(a.as_ref().ok().and_then(|v| v.as_ref().ok()), Some(&*one));
/// }
/// ```
pub fn planar(
    candidates: &[planar_solver::Candidate],
    settings: &Settings,
    out: &mut Vec<PlanarAnswer>,
) {
    planar_with(candidates, settings, Threads::Available, out);
}

/// [`planar`] on at most `threads` threads.
pub fn planar_with(
    candidates: &[planar_solver::Candidate],
    settings: &Settings,
    threads: Threads,
    out: &mut Vec<PlanarAnswer>,
) {
    in_runs(candidates, settings, threads, out, planar::solve);
}

/// Answers every spatial candidate with `settings`, appending the answers to `out` in the
/// candidates' order. Each answer equals `spatial::solve(candidate, settings)`; a large batch
/// runs on the cores [`Threads::Available`] allows.
pub fn spatial(
    candidates: &[spatial_solver::Candidate],
    settings: &Settings,
    out: &mut Vec<SpatialAnswer>,
) {
    spatial_with(candidates, settings, Threads::Available, out);
}

/// [`spatial`] on at most `threads` threads.
pub fn spatial_with(
    candidates: &[spatial_solver::Candidate],
    settings: &Settings,
    threads: Threads,
    out: &mut Vec<SpatialAnswer>,
) {
    in_runs(
        candidates,
        settings,
        threads,
        out,
        spatial_solver::batch::solve,
    );
}

/// Appends `answer(c, settings, state)` for every `c` of `items` to `out`, in order, on the
/// calling thread and up to [`Threads::for_batch`]` - 1` helpers (`pool.rs`). Each thread has its
/// own `state` (storage one answer hands to the next), made by `S::default()`.
///
/// The output is first extended by placeholders (a refusal, which costs nothing to make or
/// drop), which the answers then overwrite in place.
fn in_runs<C, V, S>(
    items: &[C],
    settings: &Settings,
    threads: Threads,
    out: &mut Vec<Result<V, InvalidInput>>,
    answer: fn(&C, &Settings, &mut S) -> Result<V, InvalidInput>,
) where
    C: Clone + Send + Sync + 'static,
    V: Send + 'static,
    S: Default + 'static,
{
    let n = items.len();
    let k = threads.for_batch(n);
    if k > 1 && pool::helpers_may_join() {
        let start = out.len();
        out.resize_with(start + n, || Err(InvalidInput::CoincidentContacts));
        if pool::run(items, settings, k - 1, &mut out[start..], answer) {
            return;
        }
        out.truncate(start);
    }
    let mut state = S::default();
    out.extend(items.iter().map(|c| answer(c, settings, &mut state)));
}
