//! Rows answered in chunks, on the calling thread or shared among threads (the `threads`
//! argument), the answers put back in row order. Every row's answer is the same whichever
//! thread gave it: a row is answered alone, from its own inputs.

use crate::arrays::value_error;
use crate::columns::Columns;
use pyo3::PyResult;
use rayon::prelude::*;
use std::ops::Range;

/// Where the chunks run.
#[derive(Debug)]
pub(crate) enum Threads {
    /// The calling thread only.
    Calling,
    /// rayon's global pool: one thread a core.
    EveryCore,
    /// A pool of this many threads, made for the call.
    Pool(rayon::ThreadPool),
}

impl Threads {
    /// `None`: every core; `1`: the calling thread; `k`: `k` threads.
    pub(crate) fn from_arg(threads: Option<usize>) -> PyResult<Self> {
        match threads {
            None => Ok(Threads::EveryCore),
            Some(0) => Err(value_error(
                "threads: expected None (every core) or a count >= 1, got 0",
            )),
            Some(1) => Ok(Threads::Calling),
            Some(k) => rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .map(Threads::Pool)
                .map_err(|e| value_error(format!("threads: cannot start {k} threads: {e}"))),
        }
    }

    /// How many threads share the work.
    pub(crate) fn count(&self) -> usize {
        match self {
            Threads::Calling => 1,
            Threads::EveryCore => rayon::current_num_threads(),
            Threads::Pool(pool) => pool.current_num_threads(),
        }
    }
}

/// The answers to rows `0..n`: on the calling thread `answer(0..n)`; on threads, `answer`
/// called on consecutive ranges of at most `chunk` rows, concatenated in row order.
pub(crate) fn answer_in_chunks(
    n: usize,
    chunk: usize,
    threads: &Threads,
    answer: impl Fn(Range<usize>) -> Columns + Sync,
) -> Columns {
    if matches!(threads, Threads::Calling) {
        // One range: the columns are written once, where they stay (no chunks to join).
        return answer(0..n);
    }
    let chunk = chunk.max(1);
    let ranges: Vec<Range<usize>> = (0..n)
        .step_by(chunk)
        .map(|start| start..(start + chunk).min(n))
        .collect();
    let parts: Vec<Columns> = match threads {
        _ if ranges.len() <= 1 => ranges.into_iter().map(&answer).collect(),
        Threads::Calling => ranges.into_iter().map(&answer).collect(),
        Threads::EveryCore => ranges.into_par_iter().map(&answer).collect(),
        Threads::Pool(pool) => pool.install(|| ranges.into_par_iter().map(&answer).collect()),
    };
    let mut out = Columns::with_capacity(n);
    for part in parts {
        out.append(part);
    }
    out
}
