//! Many candidates in one call: [`planar`] and [`spatial`] answer a slice of grasps with the
//! same settings, in order, each answer equal bit for bit to what [`crate::planar::solve`] or
//! [`crate::spatial::solve`] gives for that grasp alone.
//!
//! # Layout, and why
//! Where one planar grasp spends its time (`perf record` of `benches/batch.rs`, norm2 from
//! above, 1,000 random grasps with force closure, release build):
//!
//! | share | what |
//! |---|---|
//! | 27 % | the C library's `sin_cos` and `atan2`: the ends and minima of the envelope's pieces (`planar/analysis.rs`, `Angle::new` in `sinusoid.rs`), the current gravity angle and the ranges (`planar/frame.rs`, `planar/paper.rs`), the stationary points of the quadratic forms (`QuadForm::minima_between`, `sinusoid.rs`) |
//! | 26 % | the closed forms of the paper and the walk of the envelope (`Analysis::new`, `planar/analysis.rs`; `planar/paper.rs`): data-dependent branches, two to six pieces a grasp |
//! | 9 % | the SIMD `atan2` of the ten crossings (`rising_zeros`, `sinusoid.rs`), four a call |
//! | 17 % | recommend, evaluate, local minima and labels (`planar/analysis.rs`, `planar/curve.rs`) |
//! | 12 % | validation and the map into the paper frame (`planar/frame.rs`) |
//! | 6 % | allocation and copying the answer (its box, its list of minima, the pieces) |
//!
//! Nothing large is both vectorisable and exact. A vector `sin_cos` or `atan2` across grasps
//! gives other bits than the C library's (the `wide` crate's `atan2` is within 4.4e-16 rad of
//! it, `sinusoid.rs`), and the answer is made of decisions on those values (which bound is on
//! top, which candidate point is lowest, which ties): an angle one rounding away can change a
//! label or a tie-break, which is not "the same answer". The walk of the envelope is a short,
//! data-dependent sequence per grasp. So the batch keeps each grasp's arithmetic as the single
//! path's (the very same functions, so the answers are equal bit for bit, every field, and
//! refusals included) and takes its gain where it is exact: the grasps are independent, so a
//! large batch is answered on every core: the calling thread and helper threads started once
//! (`batch/pool.rs`, which says why not threads per batch) each take the next piece of 32 grasps
//! not yet taken, and the calling thread never waits long for a helper the machine does not
//! schedule (it answers that piece itself). Helpers join only for [`MIN_PER_THREAD`] grasps a
//! thread or more: handing work over costs microseconds, so a small batch stays on the calling
//! thread. On one thread the batch saves what the single path allocates and copies per grasp
//! (the answer's box, the storage of the envelope's pieces, handed on from grasp to grasp).
//!
//! The mathematics shared is all of the single path's: `planar/frame.rs` (validation, paper
//! frame), `planar/paper.rs` (closed forms, force closure), `planar/analysis.rs` and
//! `planar/curve.rs` (envelope, objective, minima), `spatial/plane.rs` and `spatial/on_axis.rs`
//! (the reduction to the grasp plane).

mod planar;
mod pool;

pub use crate::spatial::batch::SpatialAnswer;
pub use planar::PlanarAnswer;

use crate::{planar as planar_solver, spatial as spatial_solver, InvalidInput, Settings};
use std::num::NonZeroUsize;

/// The fewest grasps a thread of the batch is started for (see the module docs): below
/// `2 × MIN_PER_THREAD` grasps the batch runs on the calling thread alone.
pub const MIN_PER_THREAD: usize = 256;

/// Grasps a thread of the batch takes at a time: about 30 µs of work, against a lock taken and
/// released once per piece.
const PIECE: usize = 32;

/// How many threads a batch may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threads {
    /// As many as [`std::thread::available_parallelism`] says, when the batch is large enough.
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
    if k > 1 {
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
