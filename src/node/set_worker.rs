//! Sets are solved on a thread of their own, the set thread, so that a large or slow set holds up
//! nothing else: the node's thread goes on answering single candidates, parameter requests and
//! signals while a set is solved, and only publishes the set's answer once it is ready.
//!
//! ```text
//! node thread   set from DDS ── SetWorker::submit ──► queue ──► set thread: answer_set_within ──┐
//!               (max_queued_sets already waiting: STATUS_BUSY at once)                         │
//!               answer published ◄── SetWorker::done ◄── SetDone ◄─────────────────────────────┘
//! clock thread  raises the Interrupt when the set's max_set_time runs out
//! ```
//!
//! Each set's solving stops between two candidates when its `max_set_time` runs out (the clock
//! thread raises [`Interrupt`]) or when the node stops ([`SetWorker::stop`]): the candidates not
//! solved get `STATUS_NOT_SOLVED` and the set `STATUS_INCOMPLETE` (`answer_set_within`). A set that
//! arrives while `max_queued_sets` sets wait is answered at once with `STATUS_BUSY`.
//!
//! A pose set's object is made on a loader thread ([`Loaders`]) when its mesh must be loaded or
//! a large inline mesh indexed, and waited for no longer than `max_mesh_load_time` nor than the
//! set's `max_set_time`: a load that never ends costs the set thread that time, not the thread.
//! A panic while a set is answered is contained to that set ([`std::panic::catch_unwind`]): the
//! set gets status 2 "internal error", the panic is logged, and the set thread goes on with the
//! next, so that the count of sets in hand stays true and `STATUS_BUSY` means sets really wait.

use super::answer::{load_time, RecordedSet, SetInput, SetOutcome, SetReply};
use super::loads::Loaders;
use super::params::Shared;
pub(crate) use super::set_io::Via;
use super::set_kinds::Solving;
use crate::answer::{solver_pool, Answering, Halt, Interrupt, PARALLEL_FROM};
use crate::msg::MarkerArray;
use futures::channel::mpsc::{unbounded, UnboundedReceiver, UnboundedSender};
use grasp_orient_geometry::MeshCache;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// One set for the set thread, with what its answer needs.
#[derive(Debug)]
pub(crate) struct SetJob {
    /// The set.
    pub(crate) set: SetInput,
    /// When it was received and sent, ns since the epoch (its settings are those in force when
    /// it was received).
    pub(crate) received: u64,
    /// When it was sent.
    pub(crate) sent: u64,
    /// Where the answer goes.
    pub(crate) via: Via,
    /// Whether the recording was on when the set was taken: its answer is then cloned for it.
    pub(crate) record: bool,
    /// Whether the recording takes markers.
    pub(crate) record_markers: bool,
    /// Whether `grip_markers` had a subscriber when the set was taken: the best candidate is
    /// drawn only for it or for the recording.
    pub(crate) audience: bool,
}

/// A set's answer, back from the set thread.
#[derive(Debug)]
pub(crate) struct SetDone {
    /// Where the answer goes.
    pub(crate) via: Via,
    /// The answer, its markers and what to record.
    pub(crate) outcome: SetOutcome,
    /// From the node's thread handing the set over to the set thread starting it.
    pub(crate) waited: Duration,
    /// The solving, the ranking, the best candidate's markers and the recording's copy.
    pub(crate) took: Duration,
}

/// The set thread, its queue and its clock.
#[derive(Debug)]
pub(crate) struct SetWorker {
    jobs: Option<mpsc::Sender<(SetJob, Instant)>>,
    /// The answers, as they are ready.
    pub(crate) done: UnboundedReceiver<SetDone>,
    /// Sets handed over and not yet answered, the one being solved among them.
    in_hand: Arc<AtomicUsize>,
    interrupt: Arc<Interrupt>,
    clock: Arc<Clock>,
    thread: Option<std::thread::JoinHandle<()>>,
    shared: Shared,
}

impl SetWorker {
    /// Starts the set thread and its clock, answering with `shared`'s settings (with `echo`, an
    /// empty answer per candidate, nothing solved) and pose sets' meshes from `meshes` (the
    /// node's cache: a mesh named by a set is loaded off the node's thread, on one of
    /// `loaders`' threads).
    pub(crate) fn start(
        shared: Shared,
        echo: bool,
        meshes: Arc<MeshCache>,
        loaders: Arc<Loaders>,
    ) -> std::io::Result<Self> {
        let interrupt = Arc::new(Interrupt::default());
        let clock = Clock::start(interrupt.clone())?;
        let (jobs, queue) = mpsc::channel::<(SetJob, Instant)>();
        let (answers, done) = unbounded();
        let in_hand = Arc::new(AtomicUsize::new(0));
        let solver = Solver {
            shared: shared.clone(),
            echo,
            pool: std::cell::OnceCell::new(),
            interrupt: interrupt.clone(),
            clock: clock.clone(),
            meshes,
            loaders,
        };
        let counter = in_hand.clone();
        let thread = std::thread::Builder::new()
            .name("sets".into())
            .spawn(move || solver.work(&queue, &answers, &counter))?;
        Ok(Self {
            jobs: Some(jobs),
            done,
            in_hand,
            interrupt,
            clock,
            thread: Some(thread),
            shared,
        })
    }

    /// Hands `job` to the set thread; when `max_queued_sets` sets already wait behind the one
    /// being solved (or the node is stopping), its answer at once instead: `STATUS_BUSY`, nothing
    /// solved.
    pub(crate) fn submit(&self, job: SetJob) -> Result<(), Box<SetDone>> {
        let (max_queued, rules) = {
            let live = self.shared.lock();
            let version = live.version_at(job.received);
            let max = usize::try_from(version.config.max_queued_sets).unwrap_or(0);
            (max, version.config.rules())
        };
        // Only this thread adds; the set thread takes away, so the count can only have fallen
        // since it was read.
        if self.in_hand.load(Ordering::SeqCst) <= max_queued {
            if let Some(jobs) = &self.jobs {
                self.in_hand.fetch_add(1, Ordering::SeqCst);
                match jobs.send((job, Instant::now())) {
                    Ok(()) => return Ok(()),
                    Err(mpsc::SendError((back, _))) => {
                        // The set thread has ended (it never should: a set's panic is
                        // contained); no set waits, so the answer says so rather than "busy".
                        self.in_hand.fetch_sub(1, Ordering::SeqCst);
                        let why = "internal error: the set thread has ended; nothing was \
                                   solved (logged)";
                        return Err(Box::new(failed(back, &rules, why)));
                    }
                }
            }
        }
        Err(Box::new(refused(job, max_queued, &rules)))
    }

    /// Stops: the set being solved stops between two candidates, and those still waiting are
    /// answered with every candidate not solved; the set thread ends after them. Their answers
    /// still come on [`SetWorker::done`], which ends after the last.
    pub(crate) fn stop(&mut self) {
        self.interrupt.raise(Halt::Stopping);
        self.jobs = None;
        self.clock.quit();
    }

    /// Whether the set thread has ended (its last answer sent).
    pub(crate) fn ended(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }
}

impl Drop for SetWorker {
    /// Stops, and joins the set thread when it has ended; one still inside a long candidate is
    /// left to the end of the process rather than waited for.
    fn drop(&mut self) {
        self.stop();
        if let Some(thread) = self.thread.take() {
            if thread.is_finished() {
                thread.join().ok();
            } else {
                log::warn!("the set thread is still solving a candidate; not waiting for it");
            }
        }
    }
}

/// The answer to a set refused because the queue is full (or the node is stopping).
fn refused(job: SetJob, max_queued: usize, rules: &crate::answer::Rules) -> SetDone {
    let reply = job.set.busy(rules, max_queued);
    done_at_once(job, reply)
}

/// The answer to a set that cannot be answered: status 2 saying `why`, nothing solved.
fn failed(job: SetJob, rules: &crate::answer::Rules, why: &str) -> SetDone {
    let reply = job.set.failed(rules, why);
    done_at_once(job, reply)
}

/// What an internal error while answering a set says.
const SET_PANICKED: &str =
    "internal error while answering the set; nothing was solved (logged): send it again, or \
     report it with the set";

/// A set's answer given at once (refused), nothing solved.
pub(crate) fn done_at_once(job: SetJob, reply: SetReply) -> SetDone {
    SetDone {
        via: job.via,
        outcome: SetOutcome {
            markers: None,
            recorded: RecordedSet::new(
                job.record.then(|| reply.clone()),
                None,
                job.set,
                job.received,
                job.sent,
            ),
            reply,
        },
        waited: Duration::ZERO,
        took: Duration::ZERO,
    }
}

/// What the set thread owns.
struct Solver {
    shared: Shared,
    echo: bool,
    /// The threads large sets are answered on, started with the first large set (none in echo
    /// mode, with `solver_threads` 1, or when they cannot start).
    pool: std::cell::OnceCell<Option<rayon::ThreadPool>>,
    interrupt: Arc<Interrupt>,
    clock: Arc<Clock>,
    /// The node's meshes.
    meshes: Arc<MeshCache>,
    /// The threads a pose set's mesh is loaded on.
    loaders: Arc<Loaders>,
}

/// The settings a set is answered with: those in force when it was received.
struct InForce {
    /// The settings, rules and closing axis, on the node's meshes.
    with: Answering,
    markers_on: bool,
    threads: i64,
    budget: f64,
    /// `max_mesh_load_time`.
    load_time: Duration,
}

impl Solver {
    /// Answers the sets of `queue` in turn until it closes, each answer sent on `answers`.
    fn work(
        &self,
        queue: &mpsc::Receiver<(SetJob, Instant)>,
        answers: &UnboundedSender<SetDone>,
        in_hand: &AtomicUsize,
    ) {
        while let Ok((job, handed)) = queue.recv() {
            let done = self.solve(job, handed.elapsed());
            in_hand.fetch_sub(1, Ordering::SeqCst);
            if answers.unbounded_send(done).is_err() {
                return;
            }
        }
    }

    /// The answer to one set, by the same rules as a single candidate's: the settings in force
    /// when it was received, and markers for the best candidate. A large set is shared among
    /// `solver_threads` threads (`set_pool`); the solving stops when `max_set_time` runs out.
    /// A panic while it is answered gives status 2 and is logged; the set thread goes on.
    fn solve(&self, job: SetJob, waited: Duration) -> SetDone {
        let started = Instant::now();
        let now = self.in_force(&job);
        let answered =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.answer(&job.set, &now)));
        let (reply, markers) = answered.unwrap_or_else(|_| {
            log::error!(
                "a set panicked while it was answered (an internal error); it is refused with \
                 status 2 and the set thread goes on"
            );
            // The solving's interrupt may be left raised for time: the next set lowers it.
            (job.set.failed(now.with.rules(), SET_PANICKED), None)
        });
        let SetJob {
            set,
            received,
            sent,
            via,
            record,
            record_markers,
            ..
        } = job;
        let recorded = RecordedSet::new(
            record.then(|| reply.clone()),
            markers.as_ref().filter(|_| record_markers).cloned(),
            set,
            received,
            sent,
        );
        SetDone {
            via,
            outcome: SetOutcome {
                reply,
                markers,
                recorded,
            },
            waited,
            took: started.elapsed(),
        }
    }

    /// The settings a set received at `job.received` is answered with.
    fn in_force(&self, job: &SetJob) -> InForce {
        let (received, record_markers, audience) = (job.received, job.record_markers, job.audience);
        {
            let live = self.shared.lock();
            let version = live.version_at(received);
            InForce {
                with: version.answering(&self.meshes),
                markers_on: version.config.publish_markers && (audience || record_markers),
                threads: version.config.solver_threads,
                budget: version.config.max_set_time,
                load_time: load_time(version.config.max_mesh_load_time),
            }
        }
    }

    /// A set's answer and its best member's markers: solved with the set's clock running, on
    /// the pool when it is large ([`SetInput::solve`]); in echo mode, an empty answer per member.
    fn answer(&self, set: &SetInput, now: &InForce) -> (SetReply, Option<MarkerArray>) {
        #[cfg(test)]
        if set.id() == tests::PANICS {
            panic!("a panic injected by a test");
        }
        if self.echo {
            return (set.echo(), None);
        }
        let pool = self.pool_for(set.members(), now.threads);
        self.interrupt.lower_time();
        let _watched = self.clock.watch(now.budget);
        set.solve(&Solving {
            with: &now.with,
            pool,
            interrupt: &self.interrupt,
            budget: now.budget,
            markers_on: now.markers_on,
            meshes: &self.meshes,
            loaders: &self.loaders,
            load_time: now.load_time,
        })
    }

    /// The pool for a set of `members`, when it is large (started with the first large set).
    fn pool_for(&self, members: usize, threads: i64) -> Option<&rayon::ThreadPool> {
        if members >= PARALLEL_FROM {
            // `solver_threads` is fixed: the pool is started once, with the first large set.
            self.pool.get_or_init(|| set_pool(threads)).as_ref()
        } else {
            None
        }
    }
}

/// The threads a large set is answered on: `threads` of them (parameter `solver_threads`), or one
/// per core for 0, counting the set thread, which asks for the pool with its first large set and
/// solves its share of each (`answer::solver_pool`); none for 1, or when the system refuses them
/// (then the set thread answers alone).
/// While a set is solved the DDS threads have little to do (the set has arrived and its answer is
/// not yet written): measured from rclpy on two cores by `benches/bench_sets.py`, two solver
/// threads answered a set of 1,000 sooner than one (`docs/performance.md`).
fn set_pool(threads: i64) -> Option<rayon::ThreadPool> {
    let threads = match usize::try_from(threads) {
        Ok(0) | Err(_) => std::thread::available_parallelism().map_or(1, |n| n.get()),
        Ok(n) => n,
    };
    if threads <= 1 {
        return None;
    }
    solver_pool(threads)
        .map_err(|e| log::warn!("{e}; sets are answered on one thread"))
        .ok()
}

/// The clock of a set's `max_set_time`: a thread that raises [`Halt::OutOfTime`] when the
/// deadline it watches passes, so that the solving reads one atomic per candidate rather than the
/// time.
#[derive(Debug)]
struct Clock {
    state: Mutex<ClockState>,
    wake: Condvar,
    interrupt: Arc<Interrupt>,
}

#[derive(Debug, Default)]
struct ClockState {
    deadline: Option<Instant>,
    quit: bool,
}

/// A deadline being watched; dropped, it is no longer (no raise can follow the drop).
struct Watched<'a>(&'a Clock);

impl Drop for Watched<'_> {
    fn drop(&mut self) {
        self.0.lock().deadline = None;
    }
}

impl Clock {
    fn start(interrupt: Arc<Interrupt>) -> std::io::Result<Arc<Self>> {
        let clock = Arc::new(Self {
            state: Mutex::new(ClockState::default()),
            wake: Condvar::new(),
            interrupt,
        });
        let ticking = clock.clone();
        std::thread::Builder::new()
            .name("set-clock".into())
            .spawn(move || ticking.run())?;
        Ok(clock)
    }

    fn lock(&self) -> MutexGuard<'_, ClockState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Watches `seconds` from now (none for 0) until the guard is dropped.
    fn watch(&self, seconds: f64) -> Watched<'_> {
        let limit = (seconds > 0.0)
            .then(|| Duration::try_from_secs_f64(seconds).ok())
            .flatten();
        self.lock().deadline = limit.and_then(|d| Instant::now().checked_add(d));
        self.wake.notify_one();
        Watched(self)
    }

    fn quit(&self) {
        self.lock().quit = true;
        self.wake.notify_one();
    }

    /// Waits for deadlines and raises the interrupt at each (under the lock, so that a deadline
    /// no longer watched is never raised).
    fn run(&self) {
        let mut state = self.lock();
        while !state.quit {
            state = match state.deadline {
                None => self.wake.wait(state).unwrap_or_else(|e| e.into_inner()),
                Some(at) => {
                    let now = Instant::now();
                    if now >= at {
                        self.interrupt.raise(Halt::OutOfTime);
                        state.deadline = None;
                        state
                    } else {
                        self.wake
                            .wait_timeout(state, at - now)
                            .map_or_else(|e| e.into_inner().0, |(s, _)| s)
                    }
                }
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::answer::PoseAnswerer;
    use crate::config::Config;
    use crate::kind::{PoseSets, Sets};
    use crate::msg::{
        GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet,
    };
    use futures::StreamExt;
    use grasp_orient_geometry::ClosingAxis;
    use grasp_orient_geometry::MeshCache;

    /// The id of a set whose answering panics (`Solver::answer`).
    pub(super) const PANICS: &str = "test: this set panics";

    fn worker(config: Config) -> SetWorker {
        let settings = config.solver_settings().expect("valid");
        let loaders = Loaders::new(crate::node::loads::MAX_LOADERS);
        SetWorker::start(Shared::new(config, settings), false, meshes(), loaders).expect("threads")
    }

    fn meshes() -> Arc<MeshCache> {
        Arc::new(MeshCache::new(
            grasp_orient_geometry::AmentIndex::default(),
            1 << 20,
        ))
    }

    fn paper_case() -> GraspCandidate {
        let line = include_str!("../../examples/paper_cases.jsonl")
            .lines()
            .next();
        serde_json::from_str(line.expect("a case")).expect("a GraspCandidate")
    }

    /// `n` copies of a paper case with an uncertain centre of mass (the robust solver).
    fn job(id: &str, n: usize) -> SetJob {
        let mut c = paper_case();
        c.center_of_mass_tolerance.x = 0.01;
        SetJob {
            set: SetInput::new::<Sets>(GraspCandidateSet {
                id: id.into(),
                candidates: vec![c; n],
                ..GraspCandidateSet::default()
            }),
            received: crate::record::now_ns(),
            sent: 0,
            via: Via::Topic {
                taken: Duration::ZERO,
            },
            record: false,
            record_markers: false,
            audience: true,
        }
    }

    fn next(w: &mut SetWorker) -> SetDone {
        futures::executor::block_on(w.done.next()).expect("an answer")
    }

    fn unsolved(reply: &GripRecommendationSet) -> usize {
        reply
            .recommendations
            .iter()
            .filter(|r| r.status == GripRecommendation::STATUS_NOT_SOLVED)
            .count()
    }

    /// Without a budget, the node's thread hands a set over at once and the answer comes back
    /// whole, the same as the library's.
    #[test]
    fn a_set_is_solved_on_the_set_thread_and_comes_back_whole() {
        let mut w = worker(Config {
            max_set_time: 0.0,
            ..Config::default()
        });
        let mut j = job("whole", 300);
        let set = j.set.get_mut::<Sets>().expect("a candidate set");
        let want = crate::answer::answer_set(
            set,
            &Config::default().solver_settings().expect("valid"),
            &Config::default().rules(),
        );
        let handed = Instant::now();
        w.submit(j).expect("taken");
        assert!(
            handed.elapsed() < Duration::from_millis(50),
            "handing over waited"
        );
        let done = next(&mut w);
        assert_eq!(
            format!("{:?}", done.outcome.reply.candidates()),
            format!("{want:?}")
        );
        assert!(
            done.outcome.markers.is_some(),
            "markers of the best candidate"
        );
    }

    /// With nobody subscribed to `grip_markers` and no recording of markers, the best candidate
    /// is not drawn; a recording that takes markers has them drawn.
    #[test]
    fn a_set_is_drawn_only_for_a_subscriber_or_a_recording() {
        let mut w = worker(Config {
            max_set_time: 0.0,
            ..Config::default()
        });
        let unheard = SetJob {
            audience: false,
            ..job("unheard", 3)
        };
        w.submit(unheard).expect("taken");
        let done = next(&mut w);
        assert!(!done.outcome.reply.candidates().ranking.is_empty());
        assert!(done.outcome.markers.is_none(), "drawn for nobody");
        let recorded = SetJob {
            audience: false,
            record: true,
            record_markers: true,
            ..job("recorded", 3)
        };
        w.submit(recorded).expect("taken");
        assert!(
            next(&mut w).outcome.markers.is_some(),
            "drawn for the recording"
        );
    }

    /// max_set_time cuts a set that would take longer: status incomplete, the rest status 4.
    #[test]
    fn a_set_past_max_set_time_is_answered_in_part() {
        let mut w = worker(Config {
            max_set_time: 0.02,
            max_set_size: 1_000_000,
            ..Config::default()
        });
        w.submit(job("slow", 100_000)).expect("taken");
        let done = next(&mut w);
        let reply = done.outcome.reply.candidates();
        assert_eq!(reply.status, GripRecommendationSet::STATUS_INCOMPLETE);
        assert!(
            reply.message.contains("max_set_time (0.02 s) ran out"),
            "{}",
            reply.message
        );
        let left = unsolved(reply);
        assert!(left > 0 && left < 100_000, "{left} not solved");
        // The next set has a budget of its own.
        w.submit(job("next", 10)).expect("taken");
        assert_eq!(next(&mut w).outcome.reply.status(), 0);
    }

    /// A set that arrives while max_queued_sets wait is refused at once, nothing solved.
    #[test]
    fn a_full_queue_refuses_at_once() {
        let mut w = worker(Config {
            max_set_time: 0.0,
            max_queued_sets: 1,
            max_set_size: 1_000_000,
            ..Config::default()
        });
        w.submit(job("solved", 100_000)).expect("taken");
        w.submit(job("waiting", 10)).expect("one may wait");
        let refused = w.submit(job("refused", 10)).expect_err("a full queue");
        assert_eq!(
            refused.outcome.reply.status(),
            GripRecommendationSet::STATUS_BUSY
        );
        assert!(refused
            .outcome
            .reply
            .message()
            .contains("max_queued_sets 1"));
        // A pose set too, with one answer per pose (no geometry) and the poses' ids.
        let poses = pose_job("poses refused", &["a", "b"]);
        let refused = w.submit(poses).expect_err("a full queue");
        let reply = refused.outcome.reply.get::<PoseSets>();
        let reply = reply.expect("a pose set's answer");
        assert_eq!(reply.status, GripRecommendationSet::STATUS_BUSY);
        assert_eq!(reply.set_id, "poses refused");
        assert!(reply.recommendations.is_empty(), "{reply:?}");
        w.stop();
    }

    /// A stop cuts the set being solved and answers those waiting unsolved, at once.
    #[test]
    fn a_stop_answers_every_set_held_at_once() {
        let mut w = worker(Config {
            max_set_time: 0.0,
            max_set_size: 1_000_000,
            ..Config::default()
        });
        w.submit(job("long", 100_000)).expect("taken");
        w.submit(job("waiting", 1000)).expect("taken");
        std::thread::sleep(Duration::from_millis(20));
        let stopped = Instant::now();
        w.stop();
        let long = next(&mut w);
        let waiting = next(&mut w);
        assert!(
            stopped.elapsed() < Duration::from_millis(500),
            "{:?}",
            stopped.elapsed()
        );
        assert!(futures::executor::block_on(w.done.next()).is_none());
        assert!(
            w.ended() || {
                std::thread::sleep(Duration::from_millis(100));
                w.ended()
            }
        );
        for (done, id) in [(&long, "long"), (&waiting, "waiting")] {
            let reply = done.outcome.reply.candidates();
            assert_eq!((reply.set_id.as_str(), reply.status), (id, 3));
            assert!(reply.message.contains("stopping"), "{}", reply.message);
            assert!(done.outcome.markers.is_none());
        }
        assert_eq!(unsolved(waiting.outcome.reply.candidates()), 1000);
        assert!(w.submit(job("late", 1)).is_err(), "refused after a stop");
    }

    /// A set of gripper poses on a 66 mm can (a cylinder primitive), one per id, across it at
    /// its middle, moved along the can's axis by 1 cm each.
    fn pose_job(id: &str, ids: &[&str]) -> SetJob {
        let line = format!(
            r#"{{"header": {{"frame_id": "base_link"}}, "id": "{id}", "object": {{"pose": {{"position": {{"x": 0.5, "y": 0.0, "z": 0.06}}, "orientation": {{"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}, "primitive": {{"type": 3, "dimensions": [0.12, 0.033]}}, "mass": 0.35, "friction": 0.5}}, "poses": [], "gravity": {{"x": 0.0, "y": 0.0, "z": -9.81}}}}"#
        );
        let mut set = SetInput::new::<PoseSets>(serde_json::from_str(&line).expect("a pose set"));
        let poses = &mut set.get_mut::<PoseSets>().expect("a pose set").poses;
        for (k, pose_id) in ids.iter().enumerate() {
            let mut pose = crate::msg::GraspPose {
                id: (*pose_id).into(),
                width: 0.085,
                ..Default::default()
            };
            pose.grasp_pose.position.x = 0.5;
            pose.grasp_pose.position.z = 0.05 + 0.01 * k as f64;
            pose.grasp_pose.orientation.w = 1.0;
            poses.push(pose);
        }
        SetJob {
            set,
            received: crate::record::now_ns(),
            sent: 0,
            via: Via::Topic {
                taken: Duration::ZERO,
            },
            record: true,
            record_markers: false,
            audience: true,
        }
    }

    /// A pose set goes through the set thread as a candidate set does: the answer is the
    /// answer layer's, with the best pose drawn (its object and its fingers among the markers).
    #[test]
    fn a_pose_set_is_solved_on_the_set_thread() {
        let config = Config {
            max_set_time: 0.0,
            ..Config::default()
        };
        let mut w = worker(config.clone());
        let mut j = pose_job("can", &["low", "mid", "high"]);
        let set = j.set.get_mut::<PoseSets>().expect("a pose set");
        let settings = config.solver_settings().expect("valid");
        let want = PoseAnswerer::sharing(ClosingAxis::Y, meshes()).answer_set(
            set,
            &settings,
            &config.rules(),
        );
        w.submit(j).expect("taken");
        let done = next(&mut w);
        let reply = done
            .outcome
            .reply
            .get::<PoseSets>()
            .expect("a pose set's answer");
        assert_eq!(format!("{reply:?}"), format!("{want:?}"));
        assert_eq!(reply.ranking.len(), 3, "{reply:?}");
        let markers = done.outcome.markers.as_ref().expect("the best pose drawn");
        let names: Vec<&str> = markers.markers.iter().map(|m| m.ns.as_str()).collect();
        assert!(
            names.contains(&"object") && names.contains(&"fingers"),
            "{names:?}"
        );
    }

    /// `n` answers of the set thread, each within `within` (a set thread that died, or blocks,
    /// fails here rather than hanging the test).
    fn answers_within(w: &mut SetWorker, n: usize, within: Duration) -> Vec<SetDone> {
        smol::block_on(async {
            let mut out = Vec::new();
            for _ in 0..n {
                let next = futures::future::select(w.done.next(), smol::Timer::after(within)).await;
                match next {
                    futures::future::Either::Left((Some(done), _)) => out.push(done),
                    futures::future::Either::Left((None, _)) => {
                        panic!("the set thread ended after {} answers", out.len())
                    }
                    futures::future::Either::Right(_) => {
                        panic!("no answer within {within:?} after {}", out.len())
                    }
                }
            }
            out
        })
    }

    /// A set whose answering panics gets status 2 "internal error"; the set thread goes on, so
    /// more such sets than max_queued_sets are each answered the same, and later sets of
    /// candidates and of poses are answered as usual, none refused as busy.
    #[test]
    fn a_set_that_panics_is_refused_and_the_set_thread_goes_on() {
        let mut w = worker(Config {
            max_set_time: 0.0,
            max_queued_sets: 2,
            ..Config::default()
        });
        for round in 0..6 {
            w.submit(job(PANICS, 3)).expect("taken");
            let done = answers_within(&mut w, 1, Duration::from_secs(5)).remove(0);
            let reply = done.outcome.reply.candidates();
            assert_eq!(
                reply.status,
                GripRecommendationSet::STATUS_INVALID_INPUT,
                "round {round}"
            );
            assert!(
                reply.message.contains("internal error while answering"),
                "{}",
                reply.message
            );
        }
        let mut pose = pose_job(PANICS, &["a"]);
        pose.record = false;
        w.submit(pose).expect("taken");
        let done = answers_within(&mut w, 1, Duration::from_secs(5)).remove(0);
        let reply = done
            .outcome
            .reply
            .get::<PoseSets>()
            .expect("a pose set's answer");
        assert_eq!(reply.status, GripRecommendationSet::STATUS_INVALID_INPUT);
        w.submit(job("after", 3)).expect("not busy");
        w.submit(pose_job("poses after", &["low", "mid"]))
            .expect("not busy");
        let after = answers_within(&mut w, 2, Duration::from_secs(5));
        assert_eq!(
            after[0].outcome.reply.status(),
            0,
            "{}",
            after[0].outcome.reply.message()
        );
        assert_eq!(after[0].outcome.reply.candidates().ranking.len(), 3);
        assert_eq!(
            after[1].outcome.reply.status(),
            0,
            "{}",
            after[1].outcome.reply.message()
        );
        assert_eq!(after[1].outcome.reply.ranked().0, 2);
    }

    /// A pose set whose mesh never loads (a FIFO nobody writes) is answered within its
    /// max_set_time, each pose status 2; the set thread then answers the next set at once.
    #[test]
    fn a_pose_set_waits_for_its_mesh_no_longer_than_max_set_time() {
        let dir = tempfile::tempdir().expect("a temp dir");
        let fifo = crate::node::loads::tests::fifo(dir.path(), "never.stl");
        let mut w = worker(Config {
            max_set_time: 0.3,
            max_mesh_load_time: 3.0,
            ..Config::default()
        });
        let mut set = pose_job("never", &["a", "b"]);
        let p = set.set.get_mut::<PoseSets>().expect("a pose set");
        p.object.primitive = Default::default();
        p.object.mesh = fifo.display().to_string().into();
        let since = Instant::now();
        w.submit(set).expect("taken");
        w.submit(pose_job("next", &["low"])).expect("taken");
        let done = answers_within(&mut w, 2, Duration::from_secs(2));
        let never = done[0].outcome.reply.get::<PoseSets>();
        let never = never.expect("a pose set's answer");
        assert_eq!(never.recommendations.len(), 2, "{never:?}");
        for r in &never.recommendations {
            assert_eq!(r.recommendation.status, 2, "{r:?}");
            if r.recommendation.message.contains("max_set_time") {
                assert!(since.elapsed() >= Duration::from_millis(290));
            }
        }
        assert_eq!(done[1].outcome.reply.status(), 0);
        assert!(
            since.elapsed() < Duration::from_secs(1),
            "{:?}",
            since.elapsed()
        );
        crate::node::loads::tests::release(&fifo);
    }

    #[test]
    fn solver_threads_pick_the_pool() {
        assert!(set_pool(1).is_none(), "1: the set thread alone");
        // Each pool on its own thread: the thread that asks is the pool's first worker.
        let threads = |n| {
            std::thread::spawn(move || set_pool(n).map_or(1, |p| p.current_num_threads()))
                .join()
                .expect("no panic")
        };
        assert_eq!(threads(3), 3);
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(threads(0), cores, "0: one per core");
    }
}
