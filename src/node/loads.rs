//! Meshes loaded, and inline meshes indexed, off the node's thread and off the set thread, on
//! threads of their own ([`Loaders`]), each waited for at most `max_mesh_load_time`.
//!
//! ```text
//! node thread  pose candidate ─► answered here (no mesh to load, a small inline mesh, a refusal)
//!                             └► PoseLoads: a loader thread (at most MAX_LOADING at once)
//!                                ├► queue (at most MAX_QUEUED_LOADS; beyond: status 2 at once)
//!                                └► answer when the thread is done, or status 2 at the deadline
//! set thread   pose set ─► a loader thread for its object, waited for within max_set_time
//! ```
//!
//! A load may never end (a path that blocks, a parser that takes forever): its candidate is
//! answered at its deadline, and its thread is left to finish in the background (what it loads
//! fills the cache). No more than [`MAX_LOADERS`] loader threads live at once, those left
//! behind among them: a peer that names meshes which never load can hold them all, and then
//! each further candidate that needs a load waits in the queue and is answered at its deadline
//! (or refused at once when the queue is full), while every other candidate, set and parameter
//! request is answered as usual.
//!
//! A panic while loading (a parser's bug) ends the load's thread only: its candidate gets
//! status 2 "internal error while loading".

use super::pose_work::{refused, PoseWork};
use crate::msg::{MarkerArray, PoseCandidate, PoseRecommendation};
use futures::channel::oneshot;
use futures::stream::FuturesUnordered;
use futures::StreamExt;
use std::collections::VecDeque;
use std::future::Future;
use std::pin::Pin;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The most loader threads alive at once, for the node's thread and the set thread together,
/// those whose candidate was answered at its deadline and which still run among them. Each
/// indexes at most one mesh: with `max_inline_mesh_triangles` 250,000 at about 0.4 kB a
/// triangle while it is indexed (`docs/node.md`), eight at once hold under 1 GB.
pub(crate) const MAX_LOADERS: usize = 8;

/// How many single pose candidates the node's thread has loading at once (each on a loader
/// thread), not counting those answered at their deadline whose thread still runs.
pub(crate) const MAX_LOADING: usize = 4;

/// How many single pose candidates wait for a loader thread; one more is answered at once with
/// status 2 "too many meshes loading".
pub(crate) const MAX_QUEUED_LOADS: usize = 16;

/// While candidates wait and no loader thread is free, how often the node's thread looks again
/// (a thread left behind at a deadline tells nobody when it ends).
const RETRY: Duration = Duration::from_millis(50);

/// The loader threads: how many live, and the bound.
#[derive(Debug)]
pub(crate) struct Loaders {
    alive: Arc<AtomicUsize>,
    max: usize,
}

/// Counts one loader thread alive for as long as it lives (dropped when its work ends, panic or
/// not, or when the thread could not start).
struct Alive(Arc<AtomicUsize>);

impl Drop for Alive {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

impl Loaders {
    /// At most `max` loader threads at once.
    pub(crate) fn new(max: usize) -> Arc<Self> {
        Arc::new(Self {
            alive: Arc::new(AtomicUsize::new(0)),
            max,
        })
    }

    /// How many loader threads live.
    pub(crate) fn alive(&self) -> usize {
        self.alive.load(Ordering::SeqCst)
    }

    /// The bound.
    pub(crate) fn max(&self) -> usize {
        self.max
    }

    /// Runs `work` on a loader thread of its own, a panic in it contained there (logged, and
    /// what `work` would have sent is never sent: its receiver hears the sender dropped);
    /// false, `work` not run, when [`Loaders::max`] threads live already or no thread starts.
    pub(crate) fn spawn(&self, work: impl FnOnce() + Send + 'static) -> bool {
        let reserved = self
            .alive
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < self.max).then_some(n + 1)
            });
        if reserved.is_err() {
            return false;
        }
        let alive = Alive(self.alive.clone());
        std::thread::Builder::new()
            .name("mesh-load".into())
            .spawn(move || {
                let _alive = alive;
                if std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).is_err() {
                    log::error!(
                        "a mesh load panicked (an internal error); its candidate is refused"
                    );
                }
            })
            .map_err(|e| log::warn!("cannot start a mesh loader thread: {e}"))
            .is_ok()
    }
}

/// A single pose candidate answered off the node's thread (or refused there at its deadline),
/// with its times.
#[derive(Debug)]
pub(crate) struct Loaded {
    /// The candidate.
    pub(crate) candidate: PoseCandidate,
    /// Its answer.
    pub(crate) reply: PoseRecommendation,
    /// Its markers.
    pub(crate) markers: Option<MarkerArray>,
    /// When it was received, ns since the epoch.
    pub(crate) received: u64,
    /// When it was sent.
    pub(crate) sent: u64,
}

/// A pose candidate waiting for a loader thread.
struct Queued {
    /// Shared with its loader thread once started.
    candidate: Arc<PoseCandidate>,
    work: PoseWork,
    received: u64,
    sent: u64,
    deadline: Instant,
}

/// What a candidate answered at its deadline is told.
pub(crate) fn too_slow(limit: Duration) -> String {
    format!(
        "object: its mesh was not loaded within max_mesh_load_time ({} s); the load goes on \
         in the background: send the candidate again later",
        limit.as_secs_f64()
    )
}

/// What a candidate whose load panicked is told.
pub(crate) const LOAD_PANICKED: &str = "object: internal error while loading its mesh (logged)";

/// The single pose candidates of the node's thread whose meshes load off it: those loading and
/// those waiting for a loader thread.
pub(crate) struct PoseLoads {
    loaders: Arc<Loaders>,
    running: FuturesUnordered<Pin<Box<dyn Future<Output = Loaded>>>>,
    queue: VecDeque<Box<Queued>>,
}

impl std::fmt::Debug for PoseLoads {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PoseLoads")
            .field("running", &self.running.len())
            .field("queued", &self.queue.len())
            .finish()
    }
}

impl PoseLoads {
    /// Loads on `loaders`' threads.
    pub(crate) fn new(loaders: Arc<Loaders>) -> Self {
        Self {
            loaders,
            running: FuturesUnordered::new(),
            queue: VecDeque::new(),
        }
    }

    /// Takes `candidate` (received at `received`, sent at `sent`, ns since the epoch) to be
    /// answered by `work` on a loader thread: started now, or queued; its answer at once
    /// instead (status 2) when the queue is full.
    pub(crate) fn take(
        &mut self,
        work: PoseWork,
        candidate: PoseCandidate,
        received: u64,
        sent: u64,
    ) -> Result<(), Box<Loaded>> {
        // The deadline counts from now, when the node's thread takes the candidate.
        let deadline = Instant::now() + work.load_time();
        let queued = Box::new(Queued {
            candidate: Arc::new(candidate),
            work,
            received,
            sent,
            deadline,
        });
        if !self.queue.is_empty() || self.running.len() >= MAX_LOADING {
            return self.enqueue(queued);
        }
        match self.start(queued) {
            Ok(()) => Ok(()),
            Err(queued) => self.enqueue(queued),
        }
    }

    fn enqueue(&mut self, queued: Box<Queued>) -> Result<(), Box<Loaded>> {
        if self.queue.len() >= MAX_QUEUED_LOADS {
            let why = format!(
                "object: too many meshes loading ({} loader threads busy, {} candidates waiting \
                 for one); send the candidate again later",
                self.loaders.alive(),
                self.queue.len()
            );
            return Err(Box::new(answered(*queued, &why)));
        }
        self.queue.push_back(queued);
        Ok(())
    }

    /// Starts `queued` on a loader thread, or gives it back when none is free.
    fn start(&mut self, queued: Box<Queued>) -> Result<(), Box<Queued>> {
        let (tx, rx) = oneshot::channel();
        let candidate = queued.candidate.clone();
        let on_thread = queued.candidate.clone();
        let work = queued.work.clone();
        let started = self.loaders.spawn(move || {
            let answer = work.run(&on_thread);
            // The candidate is let go first, so that the node's thread gets it back uncloned.
            drop(on_thread);
            tx.send(answer).ok();
        });
        if !started {
            drop(candidate);
            return Err(queued);
        }
        let (deadline, limit) = (queued.deadline, queued.work.load_time());
        let (received, sent) = (queued.received, queued.sent);
        self.running.push(Box::pin(async move {
            let outcome = futures::future::select(rx, smol::Timer::at(deadline)).await;
            let done = |candidate, reply, markers| Loaded {
                candidate,
                reply,
                markers,
                received,
                sent,
            };
            match outcome {
                futures::future::Either::Left((Ok((reply, markers)), _)) => {
                    done(Arc::unwrap_or_clone(candidate), reply, markers)
                }
                futures::future::Either::Left((Err(oneshot::Canceled), _)) => {
                    let reply = refused(&candidate, LOAD_PANICKED);
                    done(Arc::unwrap_or_clone(candidate), reply, None)
                }
                futures::future::Either::Right(_) => {
                    let reply = refused(&candidate, &too_slow(limit));
                    done(Arc::unwrap_or_clone(candidate), reply, None)
                }
            }
        }));
        Ok(())
    }

    /// Starts waiting candidates, in their order, while loader threads are free.
    fn pump(&mut self) {
        while self.running.len() < MAX_LOADING {
            let Some(queued) = self.queue.pop_front() else {
                return;
            };
            if let Err(queued) = self.start(queued) {
                self.queue.push_front(queued);
                return;
            }
        }
    }

    /// The next answer: a load done or past its deadline, or a waiting candidate past its
    /// deadline. Pending while there is none. Cancel-safe: nothing is taken out before the
    /// answer is returned.
    pub(crate) async fn next(&mut self) -> Loaded {
        loop {
            self.pump();
            if let Some(i) = self.queue.iter().position(|q| q.deadline <= Instant::now()) {
                if let Some(late) = self.queue.remove(i) {
                    let why = too_slow(late.work.load_time());
                    return answered(*late, &why);
                }
            }
            let earliest = self.queue.iter().map(|q| q.deadline).min();
            // A waiting candidate's deadline, or a look for a free thread, whichever is first.
            let wake = async {
                match earliest {
                    Some(at) => {
                        let retry = Instant::now() + RETRY;
                        smol::Timer::at(at.min(retry)).await;
                    }
                    None => futures::future::pending::<()>().await,
                }
            };
            if self.running.is_empty() {
                wake.await;
                continue;
            }
            let mut wake = std::pin::pin!(wake);
            match futures::future::select(self.running.next(), wake.as_mut()).await {
                futures::future::Either::Left((Some(loaded), _)) => {
                    self.pump();
                    return loaded;
                }
                futures::future::Either::Left((None, _)) | futures::future::Either::Right(_) => {}
            }
        }
    }

    /// On a stop: the answers of the candidates still waiting (status 2, not loaded), taken out.
    pub(crate) fn drain_queued(&mut self) -> Vec<Loaded> {
        let why = "object: its mesh was not loaded: the node is stopping";
        self.queue.drain(..).map(|q| answered(*q, why)).collect()
    }

    /// Whether loads are running.
    pub(crate) fn running(&self) -> bool {
        !self.running.is_empty()
    }
}

/// A waiting candidate answered without loading: status 2, saying `why`.
fn answered(q: Queued, why: &str) -> Loaded {
    Loaded {
        reply: refused(&q.candidate, why),
        candidate: Arc::unwrap_or_clone(q.candidate),
        markers: None,
        received: q.received,
        sent: q.sent,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::config::Config;
    use crate::node::answer::tests::{answerer, no_recording, pose_on, torus_inline};
    use std::path::{Path, PathBuf};

    /// A FIFO in `dir`: opening it to read blocks until a writer opens it.
    pub(crate) fn fifo(dir: &Path, name: &str) -> PathBuf {
        let path = dir.join(name);
        let made = std::process::Command::new("mkfifo")
            .arg(&path)
            .status()
            .expect("mkfifo runs");
        assert!(made.success(), "mkfifo {}", path.display());
        path
    }

    /// Lets the readers blocked on `fifo` go (they read an empty file): opened to write without
    /// blocking, which fails when nobody reads.
    pub(crate) fn release(fifo: &Path) {
        use std::os::unix::fs::OpenOptionsExt;
        // O_NONBLOCK on Linux: an open to write with no reader fails (ENXIO) instead of waiting.
        const O_NONBLOCK: i32 = 0o4000;
        std::fs::OpenOptions::new()
            .write(true)
            .custom_flags(O_NONBLOCK)
            .open(fifo)
            .ok();
    }

    fn config(load_time: f64) -> Config {
        Config {
            max_mesh_load_time: load_time,
            ..no_recording()
        }
    }

    /// Every answer of `loads`, `n` of them, each with how long after `since` it came; fails
    /// past `within`.
    fn answers(
        loads: &mut PoseLoads,
        n: usize,
        since: Instant,
        within: Duration,
    ) -> Vec<(Loaded, Duration)> {
        smol::block_on(async {
            let mut out = Vec::new();
            for _ in 0..n {
                let one = std::pin::pin!(loads.next());
                let timer = smol::Timer::after(within.saturating_sub(since.elapsed()));
                let next = futures::future::select(one, timer).await;
                match next {
                    futures::future::Either::Left((loaded, _)) => {
                        out.push((loaded, since.elapsed()))
                    }
                    futures::future::Either::Right(_) => {
                        panic!("{} of {n} answers within {within:?}", out.len())
                    }
                }
            }
            out
        })
    }

    /// Pose candidates whose mesh never loads (a FIFO nobody writes) are taken at once, more
    /// than the loaders: none runs on the caller's thread, each is answered with status 2 at its
    /// deadline, and later ones are answered too while the first threads still block.
    #[test]
    fn meshes_that_never_load_are_answered_at_their_deadline() {
        let dir = tempfile::tempdir().expect("a temp dir");
        let path = fifo(dir.path(), "never.stl");
        let a = answerer(config(0.3), false);
        let mut loads = PoseLoads::new(Loaders::new(MAX_LOADERS));
        let shape = format!(r#""mesh": "{}""#, path.display());
        let since = Instant::now();
        for round in 0..2 {
            for i in 0..6 {
                let c = pose_on(&format!("fifo {round} {i}"), &shape);
                assert!(a.answers_off_thread(&c));
                let taken = Instant::now();
                loads
                    .take(a.pose_work(crate::record::now_ns(), false), c, 0, 0)
                    .expect("taken");
                assert!(
                    taken.elapsed() < Duration::from_millis(100),
                    "taking waited {:?}",
                    taken.elapsed()
                );
            }
            for (loaded, after) in answers(&mut loads, 6, since, Duration::from_secs(3)) {
                let r = &loaded.reply.recommendation;
                assert_eq!(r.status, 2, "{r:?}");
                if r.message.contains("max_mesh_load_time (0.3 s)") {
                    assert!(after >= Duration::from_millis(290), "{after:?}");
                }
            }
        }
        assert!(
            loads.loaders.alive() <= MAX_LOADERS,
            "{}",
            loads.loaders.alive()
        );
        release(&path);
    }

    /// With every loader thread held, candidates wait (and are answered at their deadline) up
    /// to the queue's bound; one more is refused at once, naming the cause.
    #[test]
    fn a_full_queue_refuses_at_once() {
        let a = answerer(config(0.2), false);
        let mut loads = PoseLoads::new(Loaders::new(0));
        let shape = r#""mesh": "/nonexistent/held.stl""#;
        let since = Instant::now();
        for i in 0..MAX_QUEUED_LOADS {
            let c = pose_on(&format!("waits {i}"), shape);
            loads
                .take(a.pose_work(crate::record::now_ns(), false), c, 0, 0)
                .expect("waits");
        }
        let c = pose_on("one too many", shape);
        let refused = loads
            .take(a.pose_work(crate::record::now_ns(), false), c, 0, 0)
            .expect_err("full");
        let r = &refused.reply.recommendation;
        assert_eq!((r.status, r.candidate_id.as_str()), (2, "one too many"));
        assert!(
            r.message.contains("too many meshes loading"),
            "{}",
            r.message
        );
        for (loaded, after) in answers(&mut loads, MAX_QUEUED_LOADS, since, Duration::from_secs(2))
        {
            let r = &loaded.reply.recommendation;
            assert!(
                r.message.contains("max_mesh_load_time (0.2 s)"),
                "{}",
                r.message
            );
            assert!(after >= Duration::from_millis(190), "{after:?}");
        }
    }

    /// An inline mesh beyond max_inline_mesh_triangles is refused before it is indexed, naming
    /// the parameter; one at the bound is answered.
    #[test]
    fn an_inline_mesh_beyond_the_bound_is_refused_unindexed() {
        let a = answerer(
            Config {
                max_inline_mesh_triangles: 200,
                ..no_recording()
            },
            false,
        );
        let work = a.pose_work(crate::record::now_ns(), false);
        let at_bound = pose_on("200", &torus_inline(10, 10));
        assert!(work.refusal(&at_bound).is_none());
        assert_eq!(work.run(&at_bound).0.recommendation.status, 0);
        let beyond = pose_on("220", &torus_inline(10, 11));
        let reply = work.refusal(&beyond).expect("refused");
        let r = &reply.recommendation;
        assert_eq!(r.status, 2);
        assert!(
            r.message
                .contains("220 triangles, more than max_inline_mesh_triangles (200)"),
            "{}",
            r.message
        );
        assert_eq!(work.run(&beyond).0.recommendation.message, r.message);
        let mut unused = pose_on("vertices", &torus_inline(10, 10));
        let extra = unused.object.inline_mesh.vertices[0].clone();
        unused.object.inline_mesh.vertices.resize(601, extra);
        let r = work.refusal(&unused).expect("refused").recommendation;
        assert!(r.message.contains("601 vertices"), "{}", r.message);
    }
}
