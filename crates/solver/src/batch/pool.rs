//! The batch's helper threads: started once, the first time a batch is large enough, and then
//! kept waiting for work, one fewer than the cores (the calling thread is the last).
//!
//! # Why not threads started per batch
//! A thread started per batch (`std::thread::scope`) must be joined before the batch returns.
//! On a machine whose other core is busy, a new or woken thread often runs first on the
//! caller's own core, and the caller then waits for it: with scoped threads a batch of 1,000
//! grasps takes up to three times as long as the single path. Here the calling thread never
//! waits long for a helper: it answers pieces itself until none is left untaken, collects what
//! the helpers finish within [`WAIT_FOR_HELPERS`], and answers again any piece a helper has
//! taken but not finished by then (the helper's late answer is dropped). The arithmetic is the
//! same function of the same grasp either way, so the answer is the same bits whoever computes
//! it.
//!
//! # Backing off when helpers do not pay
//! When the calling thread answers less than half its fair share of a batch's pieces (`1/k` of
//! them on `k` threads), the helpers did not run beside it: a woken helper ran on the caller's
//! own core, or the caller lost its core to other work, and the batch took about as long as on
//! one thread, or longer. The next batches then run on the calling thread alone: one after the
//! first such batch, twice as many after each further one in a row, at most [`MAX_SKIP`]; a
//! batch in which the caller does its share ends the backing off. So on a machine with a free
//! core every large batch uses it, and on a busy one the helpers are tried again now and then.
//!
//! # What a helper owns
//! Helpers outlive the batch, so they cannot borrow it: a batch copies its candidates into a
//! block the helpers share (a few microseconds for 1,000 grasps), and a helper sends the answers
//! of each piece back over a channel.

use crate::Settings;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

/// Grasps a thread of the batch takes at a time: about 30 µs of work, against one atomic
/// increment and, on a helper, one message per piece.
const PIECE: usize = 32;

/// Work for a helper thread.
type Job = Box<dyn FnOnce() + Send>;

/// The helpers' queue: any waiting helper takes the next job.
#[derive(Debug)]
struct Pool {
    jobs: Mutex<Sender<Job>>,
    helpers: usize,
}

/// How long the calling thread waits, at most, for the pieces helpers have taken before it
/// answers them itself: about two pieces' work.
const WAIT_FOR_HELPERS: Duration = Duration::from_micros(60);

/// The most batches in a row that run on the calling thread alone after helpers did not pay.
const MAX_SKIP: u32 = 64;

/// Whether helpers paid lately (module docs, *Backing off*). Batches on several threads at once
/// update it without order: the rule is a rate, not an invariant.
#[derive(Debug)]
struct Backoff {
    /// Batches still to run on the calling thread alone.
    skip: AtomicU32,
    /// How many to skip after the next batch in which helpers do not pay.
    next: AtomicU32,
}

impl Backoff {
    const fn new() -> Self {
        Self {
            skip: AtomicU32::new(0),
            next: AtomicU32::new(1),
        }
    }

    /// Whether this batch is to run on the calling thread alone (counting it off if so).
    fn skips(&self) -> bool {
        self.skip
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |s| s.checked_sub(1))
            .is_ok()
    }

    /// Records a batch on `threads` threads of which the calling thread answered `own` of
    /// `pieces` pieces.
    fn record(&self, own: usize, pieces: usize, threads: usize) {
        if 2 * threads * own < pieces {
            let n = self.next.load(Ordering::Relaxed);
            self.skip.store(n, Ordering::Relaxed);
            self.next.store((2 * n).min(MAX_SKIP), Ordering::Relaxed);
        } else {
            self.next.store(1, Ordering::Relaxed);
        }
    }
}

/// The process's record of whether helpers paid lately.
static HELPERS_PAY: Backoff = Backoff::new();

/// Whether the next large batch may use helpers: `false` while backing off (module docs).
pub(super) fn helpers_may_join() -> bool {
    !HELPERS_PAY.skips()
}

/// [`std::thread::available_parallelism`], asked once: on Linux it reads the process's cgroup
/// files each time, about 50 µs here: the time of fifty grasps.
pub(super) fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, usize::from))
}

/// The pool, started on first use with one helper fewer than the cores; `None` when no helper
/// could be started (the batch then runs on the calling thread).
fn pool() -> Option<&'static Pool> {
    static POOL: OnceLock<Option<Pool>> = OnceLock::new();
    POOL.get_or_init(|| {
        let cores = cores();
        let (sender, receiver) = mpsc::channel::<Job>();
        let receiver = Arc::new(Mutex::new(receiver));
        let mut helpers = 0;
        for i in 1..cores {
            let receiver = Arc::clone(&receiver);
            let started = std::thread::Builder::new()
                .name(format!("grasp-batch-{i}"))
                .spawn(move || helper(&receiver));
            if started.is_ok() {
                helpers += 1;
            }
        }
        (helpers > 0).then(|| Pool {
            jobs: Mutex::new(sender),
            helpers,
        })
    })
    .as_ref()
}

/// A helper's life: run jobs until the queue closes (it never does while the process lives).
fn helper(receiver: &Mutex<Receiver<Job>>) {
    loop {
        let job = match receiver.lock() {
            Ok(r) => r.recv(),
            Err(_) => return,
        };
        match job {
            Ok(job) => job(),
            Err(_) => return,
        }
    }
}

/// One batch as the helpers see it.
struct Shared<C, R, S> {
    items: Vec<C>,
    settings: Settings,
    pieces: usize,
    /// The next piece not yet taken.
    next: AtomicUsize,
    answer: fn(&C, &Settings, &mut S) -> R,
}

impl<C, R, S: Default> Shared<C, R, S> {
    /// The next piece not yet taken, taken.
    fn take(&self) -> Option<usize> {
        // Only the count is shared here; the answers travel over the channel.
        let p = self.next.fetch_add(1, Ordering::Relaxed);
        (p < self.pieces).then_some(p)
    }

    /// `answer` of every grasp of `range`, into `out`.
    fn answer_into(&self, range: std::ops::Range<usize>, out: &mut [R], state: &mut S) {
        for (slot, c) in out.iter_mut().zip(&self.items[range]) {
            *slot = (self.answer)(c, &self.settings, state);
        }
    }

    /// A helper's part: pieces until none is left, each sent back as it is done.
    fn help(&self, done: &Sender<(usize, Vec<R>)>) {
        let mut state = S::default();
        while let Some(p) = self.take() {
            let answers = self.items[piece_range(p, self.items.len())]
                .iter()
                .map(|c| (self.answer)(c, &self.settings, &mut state))
                .collect();
            if done.send((p, answers)).is_err() {
                return; // the batch is over: the calling thread answered this piece itself
            }
        }
    }
}

/// Answers `items` into `out[i]` for every `i` on the calling thread and up to `extra` helpers,
/// `answer(c, settings, state)` each; `out` is as long as `items`.
///
/// Returns `false` without answering anything when there is no pool (the caller answers on its
/// own thread).
pub(super) fn run<C, R, S>(
    items: &[C],
    settings: &Settings,
    extra: usize,
    out: &mut [R],
    answer: fn(&C, &Settings, &mut S) -> R,
) -> bool
where
    C: Clone + Send + Sync + 'static,
    R: Send + 'static,
    S: Default + 'static,
{
    let Some(pool) = pool() else {
        return false;
    };
    let n = items.len();
    let pieces = n.div_ceil(PIECE);
    let shared = Arc::new(Shared {
        items: items.to_vec(),
        settings: *settings,
        pieces,
        next: AtomicUsize::new(0),
        answer,
    });
    let (done, finished) = mpsc::channel::<(usize, Vec<R>)>();
    let helpers = extra.min(pool.helpers);
    if let Ok(jobs) = pool.jobs.lock() {
        for _ in 0..helpers {
            let (shared, done) = (Arc::clone(&shared), done.clone());
            // A helper that cannot be reached leaves its share to the calling thread.
            let _ = jobs.send(Box::new(move || shared.help(&done)));
        }
    }
    drop(done);
    // The calling thread's share, straight into place.
    let mut placed = vec![false; pieces];
    let mut state = S::default();
    while let Some(p) = shared.take() {
        let range = piece_range(p, n);
        shared.answer_into(range.clone(), &mut out[range], &mut state);
        placed[p] = true;
    }
    // The helpers' pieces: what they finish in time, then the rest answered here.
    let mut missing = placed.iter().filter(|m| !**m).count();
    HELPERS_PAY.record(pieces - missing, pieces, helpers + 1);
    let deadline = Instant::now() + WAIT_FOR_HELPERS;
    while missing > 0 {
        // Polled, not slept on: a timed sleep of microseconds can last milliseconds on a busy
        // machine. Each poll yields the core, to the helper when it waits on this one.
        let got = match finished.try_recv() {
            Err(TryRecvError::Empty) if Instant::now() < deadline => {
                std::thread::yield_now();
                continue;
            }
            got => got,
        };
        let Ok((p, answers)) = got else {
            break;
        };
        for (slot, a) in out[piece_range(p, n)].iter_mut().zip(answers) {
            *slot = a;
        }
        placed[p] = true;
        missing -= 1;
    }
    for p in (0..pieces).filter(|&p| !placed[p]) {
        let range = piece_range(p, n);
        shared.answer_into(range.clone(), &mut out[range], &mut state);
    }
    true
}

/// The grasps of piece `p` of a batch of `n`.
fn piece_range(p: usize, n: usize) -> std::ops::Range<usize> {
    p * PIECE..((p + 1) * PIECE).min(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicBool;

    /// Set once the batch has returned: the helper's answers wait for it.
    static RETURNED: AtomicBool = AtomicBool::new(false);
    /// Set when a helper has taken a piece.
    static HELPER_STARTED: AtomicBool = AtomicBool::new(false);
    /// Set when a helper has answered a grasp.
    static HELPER_ANSWERED: AtomicBool = AtomicBool::new(false);

    /// Waits until `flag` is set, or 10 s.
    fn wait_for(flag: &AtomicBool) {
        let give_up = Instant::now() + Duration::from_secs(10);
        while !flag.load(Ordering::SeqCst) && Instant::now() < give_up {
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// `3c + 1`. On a helper thread only once the batch has returned (or after 10 s); on the
    /// calling thread, its first grasp only once a helper has taken a piece, so that one has.
    fn held_on_helpers(c: &u64, _: &Settings, _: &mut ()) -> u64 {
        let on_helper = std::thread::current()
            .name()
            .is_some_and(|n| n.starts_with("grasp-batch"));
        if on_helper {
            HELPER_STARTED.store(true, Ordering::SeqCst);
            wait_for(&RETURNED);
            HELPER_ANSWERED.store(true, Ordering::SeqCst);
        } else if *c == 0 {
            wait_for(&HELPER_STARTED);
        }
        3 * c + 1
    }

    /// Helpers that do not pay send the next batches to the calling thread: 1, 2, 4, … up to
    /// `MAX_SKIP` in a row, and a batch in which the caller does its share ends that.
    #[test]
    fn batches_back_off_from_helpers_that_do_not_pay() {
        let b = Backoff::new();
        assert!(!b.skips(), "no batch skips at first");
        // On 2 threads the caller's fair share of 32 pieces is 16: 7 is less than half of it.
        for run in [1, 2, 4, 8, 16, 32, 64, 64] {
            b.record(7, 32, 2);
            for _ in 0..run {
                assert!(b.skips(), "a run of {run}");
            }
            assert!(!b.skips(), "after a run of {run}");
        }
        // 8 of 32 is half the fair share: the helpers paid, and the next miss skips one again.
        b.record(8, 32, 2);
        assert!(!b.skips());
        b.record(0, 32, 2);
        assert!(b.skips());
        assert!(!b.skips());
        // On 4 threads the fair share is 8: 3 is less than half of it, 4 is not.
        b.record(4, 32, 4);
        assert!(!b.skips());
        b.record(3, 32, 4);
        assert!(b.skips());
    }

    /// A helper that takes a piece and does not finish it delays the batch by no more than the
    /// calling thread's short wait: the calling thread answers that piece itself, and every
    /// answer is in its place.
    #[test]
    fn a_helper_that_does_not_finish_delays_nothing_and_changes_nothing() {
        let items: Vec<u64> = (0..20 * PIECE as u64).collect();
        let mut out = vec![0; items.len()];
        let ran = run(&items, &Settings::default(), 1, &mut out, held_on_helpers);
        let helper_answered = HELPER_ANSWERED.load(Ordering::SeqCst);
        RETURNED.store(true, Ordering::SeqCst);
        if !ran {
            // One core: no helpers, the caller answers on its own thread.
            assert_eq!(
                std::thread::available_parallelism().map_or(1, usize::from),
                1
            );
            return;
        }
        assert!(
            HELPER_STARTED.load(Ordering::SeqCst),
            "a helper took a piece"
        );
        assert!(!helper_answered, "the batch waited for its helper");
        let want: Vec<u64> = items.iter().map(|c| 3 * c + 1).collect();
        assert_eq!(out, want);
    }
}
