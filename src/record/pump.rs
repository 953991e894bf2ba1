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
//! lock, which the writer holds for at most [`SLICE`] batches at a time, so a starved writer
//! keeps the rescuer waiting for no more than that. [`Recorder::finish`] writes what is left on
//! its caller's thread.

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
    on_stop: OnStop,
    /// [`RESCUE_BACKLOG`], lowered by tests.
    rescue_backlog: u64,
}

impl Shared {
    /// The pump; a thread that panicked while holding it leaves it as it was (every write is
    /// whole or refused by the sink).
    fn lock(&self) -> MutexGuard<'_, Pump> {
        self.pump
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn backlog(&self) -> u64 {
        let handed = self.handed.load(Ordering::Relaxed);
        handed.saturating_sub(self.taken.load(Ordering::Relaxed))
    }

    /// Takes at most `batches` batches and writes them, then flushes if [`FLUSH_EVERY`] has
    /// passed; ends the recording when the sender is gone or a write fails.
    fn turn(&self, p: &mut Pump, batches: usize) -> Turn {
        if self.ended.load(Ordering::SeqCst) {
            return Turn::Ended;
        }
        let mut turn = Turn::More;
        for _ in 0..batches {
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
            match self.turn(p, usize::MAX) {
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
        if outcome.is_err() {
            self.stopped.store(true, Ordering::SeqCst);
            (self.on_stop)();
        }
        p.outcome = Some(outcome);
        // Nothing more is taken: what is handed over from now on is refused, not kept.
        p.rx = mpsc::channel().1;
        self.ended.store(true, Ordering::SeqCst);
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
    threads: Vec<JoinHandle<()>>,
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
    pub fn start(bag: BagWriter, on_stop: OnStop) -> std::io::Result<Self> {
        Self::start_with(bag, on_stop, RESCUE_BACKLOG, true)
    }

    /// As [`Writers::start`], with the rescuer's bound, and without the writer thread when
    /// `writer` is false (tests of the rescue).
    fn start_with(
        bag: BagWriter,
        on_stop: OnStop,
        rescue_backlog: u64,
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
            on_stop,
            rescue_backlog,
        });
        let mut threads = Vec::with_capacity(2);
        let rescuer = shared.clone();
        threads.push(
            std::thread::Builder::new()
                .name("record-rescue".into())
                .spawn(move || rescue(&rescuer))?,
        );
        if writer {
            let writing = shared.clone();
            let spawned = std::thread::Builder::new()
                .name("record-writer".into())
                .spawn(move || write(&writing));
            match spawned {
                Ok(t) => threads.push(t),
                Err(e) => {
                    // The rescuer must not outlive a recorder that never started.
                    shared.ended.store(true, Ordering::SeqCst);
                    stop_threads(&mut threads);
                    return Err(e);
                }
            }
        }
        Ok(Self {
            tx: Some(tx),
            shared,
            threads,
        })
    }

    /// Hands messages over; false once the recording has ended.
    pub fn hand_over(&self, entries: Vec<Entry>) -> bool {
        let n = entries.len() as u64;
        let sent = self.tx.as_ref().is_some_and(|tx| tx.send(entries).is_ok());
        if sent {
            self.shared.handed.fetch_add(n, Ordering::Relaxed);
        }
        sent
    }

    /// Whether the recording stopped on a failure.
    pub fn has_stopped(&self) -> bool {
        self.shared.stopped.load(Ordering::SeqCst)
    }

    /// Writes what is left on this thread, closes the file, stops both threads; how the
    /// recording ended. Called again, it gives the first ending's counts (or an already-stopped
    /// error).
    pub fn finish(&mut self) -> Result<Written, RecordError> {
        drop(self.tx.take());
        let outcome = {
            let mut p = self.shared.lock();
            self.shared.drain(&mut p);
            p.outcome.take()
        };
        stop_threads(&mut self.threads);
        outcome.unwrap_or_else(|| Err(RecordError::Thread))
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

/// Joins `threads` once the recording has ended (the rescuer is woken for it).
fn stop_threads(threads: &mut Vec<JoinHandle<()>>) {
    for t in threads.iter() {
        t.thread().unpark();
    }
    for t in threads.drain(..) {
        if t.join().is_err() {
            log::error!("a recording thread panicked");
        }
    }
}

/// The writer: at idle priority, every [`BATCH_EVERY`] it writes what has come, [`SLICE`]
/// batches per hold of the lock.
fn write(shared: &Shared) {
    lower_priority();
    loop {
        std::thread::sleep(BATCH_EVERY);
        loop {
            let turn = shared.turn(&mut shared.lock(), SLICE);
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
fn rescue(shared: &Shared) {
    loop {
        std::thread::park_timeout(RESCUE_EVERY);
        if shared.ended.load(Ordering::SeqCst) {
            return;
        }
        if shared.backlog() <= shared.rescue_backlog {
            let mut p = shared.lock();
            if p.last_flush.elapsed() <= FLUSH_EVERY + RESCUE_EVERY {
                continue;
            }
            if shared.drain(&mut p) == Turn::Ended {
                return;
            }
            continue;
        }
        log::debug!(
            "the recording's writer is {} messages behind: writing them at normal priority",
            shared.backlog()
        );
        if shared.drain(&mut shared.lock()) == Turn::Ended {
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
            log::debug!("the recording's writer stays at normal priority: {e:?}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{BagWriter, Entry, Payload, Topics};

    fn writer_in(dir: &std::path::Path) -> (BagWriter, std::path::PathBuf) {
        let path = dir.join("r.mcap");
        let topics = Topics {
            candidates: "/grasp_candidates".into(),
            recommendations: "/grip_recommendations".into(),
            markers: None,
            sets: None,
            poses: None,
        };
        let bag = BagWriter::create(&path, &topics, 100).expect("create");
        (bag, path)
    }

    fn candidate(i: usize) -> Entry {
        let c = crate::msg::paper_cases().swap_remove(i % 4);
        Entry {
            payload: Payload::Candidate(Box::new(c)),
            log_time: i as u64,
            publish_time: i as u64,
        }
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
    /// what passes its bound, flushes what stays below it once the flush is overdue, and
    /// `finish` writes the rest.
    #[test]
    fn the_rescuer_writes_what_a_starved_writer_leaves() {
        let dir = tempfile::tempdir().expect("dir");
        let (bag, path) = writer_in(dir.path());
        let started = Instant::now();
        let mut w = Writers::start_with(bag, never(), 10, false).expect("start");
        let taken = |w: &Writers| w.shared.taken.load(Ordering::Relaxed);
        for i in 0..50 {
            assert!(w.hand_over(vec![candidate(i)]));
        }
        assert!(wait_until(|| taken(&w) == 50), "not rescued: {}", taken(&w));
        let before = std::fs::metadata(&path).expect("file").len();
        for i in 50..55 {
            assert!(w.hand_over(vec![candidate(i)]));
        }
        std::thread::sleep(RESCUE_EVERY * 2);
        // No flush is due before FLUSH_EVERY + RESCUE_EVERY (a machine this slow skips the check).
        if started.elapsed() < FLUSH_EVERY {
            assert_eq!(
                taken(&w),
                50,
                "taken below the bound before the flush was due"
            );
        }
        assert!(wait_until(|| taken(&w) == 55), "the overdue flush");
        assert!(
            wait_until(|| std::fs::metadata(&path).map_or(0, |m| m.len()) > before),
            "nothing flushed"
        );
        for i in 55..60 {
            assert!(w.hand_over(vec![candidate(i)]));
        }
        let written = w.finish().expect("finish");
        assert_eq!(written.candidates, 60);
        let bag = crate::record::bag::read(&path).expect("readable");
        assert_eq!(bag.candidates.len(), 60);
        assert!(!w.hand_over(vec![candidate(60)]), "taken after the end");
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
