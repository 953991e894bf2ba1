//! The threads that write a recording: a writer at idle priority, and a rescuer at normal
//! priority for when the cores are saturated.
//!
//! # Why two
//! The answering loop hands messages over and never waits ([`Recorder::record_all`]). The writer
//! takes them every [`BATCH_EVERY`] and writes a burst; at 20,000 candidates a second that burst
//! sat on a core that the answering thread or DDS's thread wanted, and was the node's lag tail
//! (`docs/performance.md`). At `SCHED_IDLE` the writer gives way at once to any thread of normal
//! policy that wakes, and runs in the gaps.
//!
//! A thread at `SCHED_IDLE` only runs when a core has nothing else to do. On cores saturated by
//! other work it would fall behind without bound, and the flush that a killed node relies on
//! would stop. It cannot raise itself back (an unprivileged thread cannot leave `SCHED_IDLE`), so
//! the rescuer, started at normal priority, wakes every [`RESCUE_EVERY`] and writes everything
//! handed over itself when the backlog passes [`RESCUE_BACKLOG`] messages or the last flush is
//! more than [`FLUSH_EVERY`] plus [`RESCUE_EVERY`] old. The two share the file writer under a
//! lock. The writer takes at most [`SLICE`] batches under one hold, and lets go after the batch
//! it is on as soon as the rescuer or [`Recorder::finish`] wants the lock; a writer preempted in
//! the middle of a batch still holds it until the kernel gives it a core again, which on
//! saturated cores a thread at `SCHED_IDLE` gets now and then, not at once. [`Recorder::finish`]
//! writes what is left on its caller's thread and does not wait for the writer to leave.
//!
//! [`Recorder::record_all`]: super::Recorder::record_all
//! [`Recorder::finish`]: super::Recorder::finish

use super::{BagWriter, Entry, OnStop, RecordError, Written, FLUSH_EVERY};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often the writer takes what the answering loop handed over.
pub(super) const BATCH_EVERY: Duration = Duration::from_millis(10);
/// How often the rescuer looks at the backlog and the last flush.
const RESCUE_EVERY: Duration = Duration::from_millis(100);
/// Messages handed over and not yet taken beyond which the rescuer writes them: a quarter of a
/// second at 20,000 candidates a second (two messages each), far above what the writer leaves
/// between two of its turns when it runs.
const RESCUE_BACKLOG: u64 = 10_000;
/// Batches the writer takes under one hold of the lock.
const SLICE: usize = 64;

/// The file writer and what feeds it, behind the lock the two threads share.
struct Pump {
    /// `None` once the recording ended (finished, or stopped on a failure).
    bag: Option<BagWriter>,
    rx: mpsc::Receiver<Vec<Entry>>,
    last_flush: Instant,
    dirty: bool,
    /// How the recording ended, once it has.
    outcome: Option<Result<Written, RecordError>>,
}

/// What one turn at the pump found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Turn {
    /// Batches are left.
    More,
    /// Nothing is waiting.
    Empty,
    /// The recording has ended.
    Ended,
}

/// What the threads, the answering loop and the recorder share.
struct Shared {
    pump: Mutex<Pump>,
    /// Messages handed over, and taken from the channel.
    handed: AtomicU64,
    taken: AtomicU64,
    /// The recording ended on a failure.
    stopped: AtomicBool,
    /// The recording ended.
    ended: AtomicBool,
    /// A thread of normal priority waits for the lock: the writer lets go after its batch.
    wanted: AtomicBool,
    on_stop: OnStop,
    /// When the rescuer steps in: [`RESCUE_BACKLOG`] and [`FLUSH_EVERY`] + [`RESCUE_EVERY`],
    /// other values in tests.
    rescue: Rescue,
}

/// When the rescuer writes.
#[derive(Debug, Clone, Copy)]
struct Rescue {
    /// More messages waiting than this.
    backlog: u64,
    /// The last flush older than this.
    flush_age: Duration,
}

impl Default for Rescue {
    fn default() -> Self {
        Self {
            backlog: RESCUE_BACKLOG,
            flush_age: FLUSH_EVERY + RESCUE_EVERY,
        }
    }
}

impl Shared {
    /// The pump; a thread that panicked while holding it leaves it as it was (every write is
    /// whole or refused by the sink).
    fn lock(&self) -> MutexGuard<'_, Pump> {
        self.pump
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The lock for a thread of normal priority: the writer lets go of it after its batch.
    fn lock_wanted(&self) -> MutexGuard<'_, Pump> {
        self.wanted.store(true, Ordering::SeqCst);
        let guard = self.lock();
        self.wanted.store(false, Ordering::SeqCst);
        guard
    }

    fn backlog(&self) -> u64 {
        let handed = self.handed.load(Ordering::Relaxed);
        handed.saturating_sub(self.taken.load(Ordering::Relaxed))
    }

    /// Takes at most `batches` batches and writes them (fewer when `give_way` and another
    /// thread wants the lock), then flushes if [`FLUSH_EVERY`] has passed; ends the recording
    /// when the sender is gone or a write fails.
    fn turn(&self, p: &mut Pump, batches: usize, give_way: bool) -> Turn {
        if self.ended.load(Ordering::SeqCst) {
            return Turn::Ended;
        }
        let mut turn = Turn::More;
        for _ in 0..batches {
            if give_way && self.wanted.load(Ordering::Relaxed) {
                break;
            }
            match p.rx.try_recv() {
                Ok(batch) => {
                    self.taken.fetch_add(batch.len() as u64, Ordering::Relaxed);
                    if let Err(e) = p.write(&batch) {
                        return self.end(p, Err(e));
                    }
                }
                Err(mpsc::TryRecvError::Empty) => {
                    turn = Turn::Empty;
                    break;
                }
                Err(mpsc::TryRecvError::Disconnected) => return self.end(p, Ok(())),
            }
        }
        match p.flush_if_due() {
            Ok(()) => turn,
            Err(e) => self.end(p, Err(e)),
        }
    }

    /// Takes and writes until nothing is waiting or the recording ended.
    fn drain(&self, p: &mut Pump) -> Turn {
        loop {
            match self.turn(p, usize::MAX, false) {
                Turn::More => {}
                other => return other,
            }
        }
    }

    /// Ends the recording: closes the file after `result`, or keeps the failure and tells
    /// `on_stop`.
    fn end(&self, p: &mut Pump, result: Result<(), RecordError>) -> Turn {
        let bag = p.bag.take();
        let outcome = match (result, bag) {
            (Ok(()), Some(bag)) => bag.finish(),
            (Ok(()), None) => Ok(Written::default()),
            (Err(e), _) => Err(e),
        };
        // Nothing more is taken: what is handed over from now on is refused, not kept (before
        // `stopped` is seen, so that a stopped recorder refuses at once).
        p.rx = mpsc::channel().1;
        let failed = outcome.is_err();
        p.outcome = Some(outcome);
        self.ended.store(true, Ordering::SeqCst);
        if failed {
            self.stopped.store(true, Ordering::SeqCst);
            (self.on_stop)();
        }
        Turn::Ended
    }
}

impl Pump {
    fn write(&mut self, batch: &[Entry]) -> Result<(), RecordError> {
        if let Some(bag) = self.bag.as_mut() {
            for entry in batch {
                bag.write(entry)?;
            }
            self.dirty = true;
        }
        Ok(())
    }

    fn flush_if_due(&mut self) -> Result<(), RecordError> {
        if self.last_flush.elapsed() >= FLUSH_EVERY {
            if self.dirty {
                if let Some(bag) = self.bag.as_mut() {
                    bag.flush()?;
                }
                self.dirty = false;
            }
            self.last_flush = Instant::now();
        }
        Ok(())
    }
}

/// The two threads of one recording, and the channel into them.
#[derive(Debug)]
pub(super) struct Writers {
    tx: Option<mpsc::Sender<Vec<Entry>>>,
    shared: Arc<Shared>,
    rescuer: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Shared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Shared")
            .field("handed", &self.handed)
            .field("taken", &self.taken)
            .field("ended", &self.ended)
            .finish_non_exhaustive()
    }
}

impl Writers {
    /// Starts the writer (at idle priority) and the rescuer (at the caller's) on `bag`.
    pub(super) fn start(bag: BagWriter, on_stop: OnStop) -> std::io::Result<Self> {
        Self::start_with(bag, on_stop, Rescue::default(), true)
    }

    /// As [`Writers::start`], with when the rescuer writes, and without the writer thread when
    /// `writer` is false (tests of the rescue).
    fn start_with(
        bag: BagWriter,
        on_stop: OnStop,
        rescue: Rescue,
        writer: bool,
    ) -> std::io::Result<Self> {
        let (tx, rx) = mpsc::channel::<Vec<Entry>>();
        let shared = Arc::new(Shared {
            pump: Mutex::new(Pump {
                bag: Some(bag),
                rx,
                last_flush: Instant::now(),
                dirty: false,
                outcome: None,
            }),
            handed: AtomicU64::new(0),
            taken: AtomicU64::new(0),
            stopped: AtomicBool::new(false),
            ended: AtomicBool::new(false),
            wanted: AtomicBool::new(false),
            on_stop,
            rescue,
        });
        let rescuing = shared.clone();
        let rescuer = std::thread::Builder::new()
            .name("record-rescue".into())
            .spawn(move || run_rescuer(&rescuing))?;
        let mut writers = Self {
            tx: Some(tx),
            shared,
            rescuer: Some(rescuer),
        };
        if writer {
            let writing = writers.shared.clone();
            // Not joined: `finish` does the writer's last work, and the writer leaves when it
            // next runs, which at idle priority may be a while.
            let spawned = std::thread::Builder::new()
                .name("record-writer".into())
                .spawn(move || run_writer(&writing));
            if let Err(e) = spawned {
                // The rescuer must not outlive a recorder that never started.
                writers.shared.ended.store(true, Ordering::SeqCst);
                writers.stop_rescuer();
                writers.tx = None;
                return Err(e);
            }
        }
        Ok(writers)
    }

    /// Hands messages over; false once the recording has ended.
    pub(super) fn hand_over(&self, entries: Vec<Entry>) -> bool {
        let n = entries.len() as u64;
        let sent = self.tx.as_ref().is_some_and(|tx| tx.send(entries).is_ok());
        if sent {
            self.shared.handed.fetch_add(n, Ordering::Relaxed);
        }
        sent
    }

    /// Whether the recording stopped on a failure.
    pub(super) fn has_stopped(&self) -> bool {
        self.shared.stopped.load(Ordering::SeqCst)
    }

    /// Writes what is left on this thread, closes the file, stops the rescuer; how the
    /// recording ended. Only the first call ends it (later ones give [`RecordError::Thread`]).
    pub(super) fn finish(&mut self) -> Result<Written, RecordError> {
        let outcome = {
            // The lock first, so that the writer does not start the closing at idle priority.
            let mut p = self.shared.lock_wanted();
            drop(self.tx.take());
            self.shared.drain(&mut p);
            p.outcome.take()
        };
        self.stop_rescuer();
        outcome.unwrap_or_else(|| Err(RecordError::Thread))
    }

    /// Wakes the rescuer to see that the recording ended, and joins it.
    fn stop_rescuer(&mut self) {
        if let Some(t) = self.rescuer.take() {
            t.thread().unpark();
            if t.join().is_err() {
                log::error!("the recording's rescuer thread panicked");
            }
        }
    }
}

impl Drop for Writers {
    fn drop(&mut self) {
        if self.tx.is_some() {
            if let Err(e) = self.finish() {
                log::error!("{e}");
            }
        }
    }
}

/// The writer: at idle priority, every [`BATCH_EVERY`] it writes what has come, [`SLICE`]
/// batches per hold of the lock.
fn run_writer(shared: &Shared) {
    lower_priority();
    loop {
        std::thread::sleep(BATCH_EVERY);
        loop {
            let turn = shared.turn(&mut shared.lock(), SLICE, true);
            match turn {
                Turn::More => {}
                Turn::Empty => break,
                Turn::Ended => return,
            }
        }
    }
}

/// The rescuer: every [`RESCUE_EVERY`], when the writer has fallen behind by more than the
/// bound or the last flush is overdue, it writes everything handed over.
fn run_rescuer(shared: &Shared) {
    loop {
        std::thread::park_timeout(RESCUE_EVERY);
        if shared.ended.load(Ordering::SeqCst) {
            return;
        }
        let backlog = shared.backlog();
        let mut p = shared.lock_wanted();
        if backlog <= shared.rescue.backlog {
            if p.last_flush.elapsed() <= shared.rescue.flush_age {
                continue;
            }
        } else {
            log::debug!(
                "the recording's writer is {backlog} messages behind: writing them at normal \
                 priority"
            );
        }
        if shared.drain(&mut p) == Turn::Ended {
            return;
        }
    }
}

/// Puts the calling thread at `SCHED_IDLE` (Linux); elsewhere, or if refused, it stays where it
/// is and the recording is as before.
fn lower_priority() {
    #[cfg(target_os = "linux")]
    {
        use thread_priority::unix::{
            set_thread_priority_and_policy, thread_native_id, NormalThreadSchedulePolicy,
            ThreadSchedulePolicy,
        };
        let idle = ThreadSchedulePolicy::Normal(NormalThreadSchedulePolicy::Idle);
        let set = set_thread_priority_and_policy(
            thread_native_id(),
            thread_priority::ThreadPriority::Min,
            idle,
        );
        if let Err(e) = set {
            log::debug!("the recording's writer's priority was not (wholly) lowered: {e:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::tests::{candidate, topics};

    fn writer_in(dir: &std::path::Path) -> (BagWriter, std::path::PathBuf) {
        let path = dir.join("r.mcap");
        let bag = BagWriter::create(&path, &topics(), 100).expect("create");
        (bag, path)
    }

    fn never() -> OnStop {
        Arc::new(|| {})
    }

    fn wait_until(what: impl Fn() -> bool) -> bool {
        let t0 = Instant::now();
        while !what() && t0.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(10));
        }
        what()
    }

    /// With no writer thread at all (as a writer that never gets a core), the rescuer writes
    /// what passes its bound, and `finish` writes the rest.
    #[test]
    fn the_rescuer_writes_what_a_starved_writer_leaves_past_the_bound() {
        let dir = tempfile::tempdir().expect("dir");
        let (bag, path) = writer_in(dir.path());
        let rescue = Rescue {
            backlog: 10,
            flush_age: Duration::from_secs(3600),
        };
        let mut w = Writers::start_with(bag, never(), rescue, false).expect("start");
        let taken = |w: &Writers| w.shared.taken.load(Ordering::Relaxed);
        for i in 0..5 {
            assert!(w.hand_over(vec![candidate(i)]));
        }
        std::thread::sleep(RESCUE_EVERY * 3);
        assert_eq!(taken(&w), 0, "taken within the bound");
        // In one hand-over: handed one by one, a rescue between two of them could leave the
        // last few within the bound, and the count below would depend on the scheduler.
        assert!(w.hand_over((5..50).map(candidate).collect()));
        assert!(wait_until(|| taken(&w) == 50), "not rescued: {}", taken(&w));
        for i in 50..55 {
            assert!(w.hand_over(vec![candidate(i)]));
        }
        let written = w.finish().expect("finish");
        assert_eq!(written.requests::<crate::kind::Candidates>(), 55);
        let bag = crate::record::bag::read(&path).expect("readable");
        assert_eq!(bag.streams.candidates.requests.len(), 55);
        assert!(!w.hand_over(vec![candidate(55)]), "taken after the end");
    }

    /// With no writer thread, the rescuer flushes what stays within its bound once the last
    /// flush is overdue.
    #[test]
    fn the_rescuer_flushes_when_a_starved_writer_has_not() {
        let dir = tempfile::tempdir().expect("dir");
        let (bag, path) = writer_in(dir.path());
        let rescue = Rescue {
            backlog: u64::MAX,
            ..Rescue::default()
        };
        let mut w = Writers::start_with(bag, never(), rescue, false).expect("start");
        let before = std::fs::metadata(&path).expect("file").len();
        for i in 0..5 {
            assert!(w.hand_over(vec![candidate(i)]));
        }
        let size = || std::fs::metadata(&path).map_or(0, |m| m.len());
        assert!(wait_until(|| size() > before), "nothing flushed");
        assert_eq!(w.shared.taken.load(Ordering::Relaxed), 5);
        assert_eq!(
            w.finish()
                .expect("finish")
                .requests::<crate::kind::Candidates>(),
            5
        );
    }

    /// The writer threads run at `SCHED_IDLE` (policy 5), the rescuers at `SCHED_OTHER` (0).
    #[cfg(target_os = "linux")]
    #[test]
    fn the_writer_runs_at_idle_priority_and_the_rescuer_does_not() {
        fn policies() -> Vec<(String, String)> {
            let mut out = Vec::new();
            for task in std::fs::read_dir("/proc/self/task")
                .expect("tasks")
                .flatten()
            {
                let comm = std::fs::read_to_string(task.path().join("comm")).unwrap_or_default();
                let stat = std::fs::read_to_string(task.path().join("stat")).unwrap_or_default();
                // Field 41 (policy), counted from 1; after the ")" that closes the name, field 3.
                let after = stat.rsplit(')').next().unwrap_or_default();
                let policy = after.split_whitespace().nth(41 - 3).unwrap_or_default();
                out.push((comm.trim().to_string(), policy.to_string()));
            }
            out
        }
        let dir = tempfile::tempdir().expect("dir");
        let (bag, _) = writer_in(dir.path());
        let mut w = Writers::start(bag, never()).expect("start");
        // Other tests start recorders meanwhile: each writer lowers itself as it starts.
        let settled = || {
            let p = policies();
            let writers: Vec<_> = p.iter().filter(|(c, _)| c == "record-writer").collect();
            let rescuers: Vec<_> = p.iter().filter(|(c, _)| c == "record-rescue").collect();
            !writers.is_empty()
                && !rescuers.is_empty()
                && writers.iter().all(|(_, p)| p == "5")
                && rescuers.iter().all(|(_, p)| p == "0")
        };
        assert!(wait_until(settled), "{:?}", policies());
        w.finish().expect("finish");
    }
}
