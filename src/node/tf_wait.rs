//! Requests that wait for their transforms, without the node's thread waiting.
//!
//! A request of any kind whose transforms ([`crate::tf::resolve`]) cannot be had yet is kept
//! here, with the settings in force when it came and a deadline `tf_timeout` later, and the node
//! goes on with the next message. Whenever transforms have come in, the waiting requests are
//! tried again ([`TfWait::ready`], at most once every [`RETRY`]): one that resolves is answered
//! then, as if it had just come; one still missing a transform at its deadline is refused with
//! status 2 and the buffer's words, which name both frames as tf2 does. At most [`MAX_WAITING`]
//! wait at once; one more is refused at once, saying so and why it would have waited.

use super::answer::SetInput;
use super::set_worker::Via;
use crate::kind::{Candidates, Framing, Poses};
use crate::msg::{GraspCandidate, PoseCandidate};
use crate::tf::{self, Gravity, TfBuffer, TfFailure, ToolFrame};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// The most requests that wait for transforms at once; one more is refused at once (status 2).
/// Each waits at most `tf_timeout` (10 s at most), so this bounds the memory they hold to what
/// that many requests already took to receive.
pub(crate) const MAX_WAITING: usize = 64;

/// After transforms arrive, how long the node lets more of them come before it tries the waiting
/// requests again: a broadcaster at 1 kHz then costs at most one try of each every 2 ms.
pub(crate) const RETRY: Duration = Duration::from_millis(2);

/// A request as it came, of any kind, and where its answer goes.
#[derive(Debug)]
pub(crate) enum Request {
    /// On `grasp_candidates`.
    Candidate(Box<GraspCandidate>),
    /// On `pose_candidates`; once turned by TF with `gravity_frame` set, with the frame its
    /// answer's tool pose goes into.
    Pose(Box<PoseCandidate>, Option<ToolFrame>),
    /// A set on its topic, in a call of its service, or made from a call of `~/rank_grasps`:
    /// where its answer goes (a topic's `taken` is set when it is handed to the set thread).
    Set(SetInput, Via),
}

/// A request and its times, ns since the epoch (a call's are both when it was taken).
#[derive(Debug)]
pub(crate) struct Arrival {
    /// The request.
    pub request: Request,
    /// When it was received: its settings are those in force then.
    pub received: u64,
    /// When it was sent.
    pub sent: u64,
}

impl Request {
    /// Whether it needs TF ([`tf::needs`], for its kind).
    fn needs(&self, gravity: &Gravity) -> bool {
        match self {
            Request::Candidate(c) => tf::needs::<Candidates>(gravity, c),
            Request::Pose(p, _) => tf::needs::<Poses>(gravity, p),
            Request::Set(s, _) => s.needs_tf(gravity),
        }
    }

    /// It turned by TF ([`tf::resolve`], for its kind), or the first transform missing.
    fn resolve(&self, buffer: &TfBuffer, gravity: &Gravity) -> Result<Request, TfFailure> {
        Ok(match self {
            Request::Candidate(c) => {
                Request::Candidate(Box::new(resolve::<Candidates>(buffer, gravity, c)?))
            }
            Request::Pose(p, _) => {
                let turned = resolve::<Poses>(buffer, gravity, p)?;
                // The same pair of frames at the same stamp as the gravity's: found when it was.
                let frame = tf::tool_frame(buffer, &gravity.frame, &p.header).transpose()?;
                Request::Pose(Box::new(turned), frame)
            }
            Request::Set(s, via) => Request::Set(s.resolve(buffer, gravity)?, *via),
        })
    }
}

fn resolve<K: Framing>(
    buffer: &TfBuffer,
    gravity: &Gravity,
    request: &K::Request,
) -> Result<K::Request, TfFailure> {
    tf::resolve::<K>(buffer, gravity, request)
}

/// What becomes of a request.
#[derive(Debug)]
pub(crate) enum Verdict {
    /// To answer now: it as it came when it needs no TF, otherwise turned by TF.
    Ready(Arrival),
    /// To refuse with status 2 and this reason (without the answer's `invalid input: `): it as
    /// it came.
    Refused(Arrival, String),
    /// Kept until its transforms come or its deadline passes.
    Waits,
}

/// One request waiting.
#[derive(Debug)]
struct Waiting {
    arrival: Arrival,
    gravity: Gravity,
    timeout: Duration,
    deadline: Instant,
}

/// The node's TF buffer and the requests waiting for it.
#[derive(Debug, Default)]
pub(crate) struct TfWait {
    /// The transforms received.
    pub buffer: TfBuffer,
    waiting: VecDeque<Waiting>,
    /// When to try the waiting requests again, set when transforms came while some wait.
    retry_at: Option<Instant>,
}

impl TfWait {
    /// An empty buffer, nothing waiting.
    pub(crate) fn new() -> Self {
        Self {
            buffer: TfBuffer::new(),
            ..Self::default()
        }
    }

    /// How many requests wait.
    #[cfg(test)]
    pub(crate) fn waiting(&self) -> usize {
        self.waiting.len()
    }

    /// Takes a request that came at `now`, with the settings in force when it was received:
    /// `gravity` (the parameters `gravity_frame` and `gravity`) and `timeout` (`tf_timeout`).
    pub(crate) fn admit(
        &mut self,
        arrival: Arrival,
        gravity: Gravity,
        timeout: Duration,
        now: Instant,
    ) -> Verdict {
        if !arrival.request.needs(&gravity) {
            return Verdict::Ready(arrival);
        }
        let failure = match arrival.request.resolve(&self.buffer, &gravity) {
            Ok(request) => return Verdict::Ready(Arrival { request, ..arrival }),
            Err(failure) => failure,
        };
        if timeout.is_zero() {
            return Verdict::Refused(arrival, failure.to_string());
        }
        if self.waiting.len() >= MAX_WAITING {
            let why = format!(
                "{failure}; and {MAX_WAITING} requests already wait for their transforms (at \
                 most tf_timeout {} s each), so this one does not",
                timeout.as_secs_f64()
            );
            return Verdict::Refused(arrival, why);
        }
        self.waiting.push_back(Waiting {
            arrival,
            gravity,
            timeout,
            deadline: now + timeout,
        });
        Verdict::Waits
    }

    /// Notes that transforms came in at `now`: the waiting requests are tried again at most
    /// [`RETRY`] later.
    pub(crate) fn arrived(&mut self, now: Instant) {
        if !self.waiting.is_empty() && self.retry_at.is_none() {
            self.retry_at = Some(now + RETRY);
        }
    }

    /// When [`TfWait::ready`] has something to do: the next retry or the earliest deadline.
    pub(crate) fn next_wake(&self) -> Option<Instant> {
        let deadline = self.waiting.iter().map(|w| w.deadline).min();
        match (self.retry_at, deadline) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// At `now`: the waiting requests that resolve (when transforms came since the last try, or
    /// at their deadline), and those past their deadline that still do not, refused naming the
    /// transform missing; in the order they came. The others go on waiting.
    pub(crate) fn ready(&mut self, now: Instant) -> Vec<Verdict> {
        let retry = self.retry_at.is_some_and(|at| at <= now);
        if retry {
            self.retry_at = None;
        }
        let mut out = Vec::new();
        let mut kept = VecDeque::with_capacity(self.waiting.len());
        for w in self.waiting.drain(..) {
            let due = w.deadline <= now;
            if !(retry || due) {
                kept.push_back(w);
                continue;
            }
            match w.arrival.request.resolve(&self.buffer, &w.gravity) {
                Ok(request) => out.push(Verdict::Ready(Arrival {
                    request,
                    ..w.arrival
                })),
                Err(failure) if due => {
                    let why = format!(
                        "{failure} (waited tf_timeout {} s)",
                        w.timeout.as_secs_f64()
                    );
                    out.push(Verdict::Refused(w.arrival, why));
                }
                Err(_) => kept.push_back(w),
            }
        }
        self.waiting = kept;
        out
    }

    /// Every request still waiting, for a node that stops: refused, saying so.
    pub(crate) fn drain_all(&mut self) -> Vec<Verdict> {
        self.retry_at = None;
        self.waiting
            .drain(..)
            .map(|w| {
                let why = "the node stopped while the request waited for its transforms";
                Verdict::Refused(w.arrival, why.to_string())
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Header, Time, TransformStamped};

    fn candidate(frame: &str, id: &str) -> Arrival {
        Arrival {
            request: Request::Candidate(Box::new(GraspCandidate {
                header: Header {
                    stamp: Time { sec: 0, nanosec: 0 },
                    frame_id: frame.into(),
                },
                id: id.into(),
                ..GraspCandidate::default()
            })),
            received: 0,
            sent: 0,
        }
    }

    fn world() -> Gravity {
        Gravity {
            frame: "world".into(),
            vector: [0.0, 0.0, -9.8],
        }
    }

    fn tool_in_world() -> TransformStamped {
        let mut t = TransformStamped::default();
        t.header.frame_id = "world".into();
        t.child_frame_id = "tool".into();
        // 180° about x: world's -z is the tool's +z.
        t.transform.rotation.x = 1.0;
        t
    }

    fn id_of(v: &Verdict) -> (&'static str, String) {
        let (what, a) = match v {
            Verdict::Ready(a) => ("ready", a),
            Verdict::Refused(a, _) => ("refused", a),
            Verdict::Waits => return ("waits", String::new()),
        };
        match &a.request {
            Request::Candidate(c) => (what, c.id.to_string()),
            _ => (what, "?".into()),
        }
    }

    /// A request missing its transform waits, the next is answered meanwhile, and the first is
    /// answered once the transform comes, turned by it; one whose transform never comes is
    /// refused at its deadline, naming both frames; with tf_timeout 0, at once.
    #[test]
    fn a_request_waits_for_its_transform_and_the_next_is_answered_meanwhile() {
        let t0 = Instant::now();
        let timeout = Duration::from_millis(100);
        let mut wait = TfWait::new();
        let mut other = TfBuffer::new();
        other.insert(&tool_in_world(), true);
        wait.buffer.insert(
            &{
                let mut t = tool_in_world();
                t.child_frame_id = "camera".into();
                t
            },
            true,
        );
        let v = wait.admit(candidate("tool", "a"), world(), timeout, t0);
        assert!(matches!(v, Verdict::Waits), "{v:?}");
        let v = wait.admit(candidate("camera", "b"), world(), timeout, t0);
        assert_eq!(id_of(&v), ("ready", "b".into()));
        let v = wait.admit(candidate("nowhere", "c"), world(), timeout, t0);
        assert!(matches!(v, Verdict::Waits));
        assert_eq!(wait.waiting(), 2);
        // Nothing came: nothing to do before the deadline.
        assert_eq!(wait.next_wake(), Some(t0 + timeout));
        assert!(wait.ready(t0 + Duration::from_millis(50)).is_empty());
        wait.buffer.insert(&tool_in_world(), true);
        wait.arrived(t0 + Duration::from_millis(60));
        assert_eq!(
            wait.next_wake(),
            Some(t0 + Duration::from_millis(60) + RETRY)
        );
        let out = wait.ready(t0 + Duration::from_millis(70));
        assert_eq!(out.len(), 1);
        let Verdict::Ready(a) = &out[0] else {
            panic!("{out:?}")
        };
        let Request::Candidate(c) = &a.request else {
            panic!("{a:?}")
        };
        assert_eq!((c.id.as_str(), c.gravity.z), ("a", 9.8));
        let out = wait.ready(t0 + timeout);
        assert_eq!(out.len(), 1);
        let Verdict::Refused(_, why) = &out[0] else {
            panic!("{out:?}")
        };
        assert_eq!(
            why,
            "no transform of the gravity from frame \"world\" to frame \"nowhere\": \"nowhere\" \
             passed to lookupTransform argument target_frame does not exist.  (waited tf_timeout \
             0.1 s)"
        );
        assert_eq!(wait.waiting(), 0);
        let v = wait.admit(candidate("nowhere", "d"), world(), Duration::ZERO, t0);
        assert_eq!(id_of(&v), ("refused", "d".into()));
    }

    /// Past MAX_WAITING waiting, the next is refused at once, saying why; a node that stops
    /// refuses those waiting.
    #[test]
    fn the_waiting_requests_are_bounded() {
        let t0 = Instant::now();
        let mut wait = TfWait::new();
        for i in 0..MAX_WAITING {
            let v = wait.admit(
                candidate("x", &i.to_string()),
                world(),
                Duration::from_secs(1),
                t0,
            );
            assert!(matches!(v, Verdict::Waits));
        }
        let v = wait.admit(candidate("x", "last"), world(), Duration::from_secs(1), t0);
        let Verdict::Refused(_, why) = v else {
            panic!("{v:?}")
        };
        assert!(
            why.ends_with("and 64 requests already wait for their transforms (at most tf_timeout 1 s each), so this one does not"),
            "{why}"
        );
        assert_eq!(wait.drain_all().len(), MAX_WAITING);
        assert_eq!(wait.waiting(), 0);
    }

    /// Without gravity_frame and without an object frame, nothing is looked up: the request
    /// is ready as it came, even with an empty buffer.
    #[test]
    fn a_request_without_frames_is_ready_as_it_came() {
        let mut wait = TfWait::new();
        let none = Gravity {
            frame: "".into(),
            vector: [0.0, 0.0, -9.8],
        };
        let v = wait.admit(
            candidate("x", "a"),
            none,
            Duration::from_secs(1),
            Instant::now(),
        );
        assert_eq!(id_of(&v), ("ready", "a".into()));
    }
}
