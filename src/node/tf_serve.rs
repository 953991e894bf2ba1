//! Every request the node takes goes through [`admit`]: the transforms already received are
//! drained into the buffer, and the request is answered at once (turned by TF where it needs
//! TF), refused, or left waiting in [`TfWait`] for its transforms without holding up the node's
//! thread. What is answered goes on to its kind's usual path ([`dispatch`]); that path records
//! the request as answered, turned by TF, so that `replay` answers it alike without TF.

use super::requests::{answer_one, send_answer, take_pose, Endpoints, Loop};
use super::session::say;
use super::set_worker::{done_at_once, SetJob, Via};
use super::sets;
use super::tf_wait::{Arrival, Request, TfWait, Verdict};
use crate::answer::Answer;
use crate::config::objects::ObjectTable;
use crate::kind::{Candidates, Poses};
use crate::msg::TfMessage;
use ros2_client::{MessageInfo, Node};
use std::time::Instant;

/// Takes `request`, received and sent at `times` (ns since the epoch), with the settings in
/// force when it was received.
pub(super) async fn admit(
    node: &Node,
    endpoints: &Endpoints,
    state: &mut Loop<'_>,
    request: Request,
    (received, sent): (u64, u64),
) {
    let mut request = request;
    fill(&mut request, state.scene.table());
    let now = Instant::now();
    let drained = endpoints.tf.drain(&mut state.tf.buffer);
    if drained.dynamic + drained.fixed > 0 {
        state.tf.arrived(now);
    }
    let (gravity, timeout) = state.answerer.tf_settings(received);
    let arrival = Arrival {
        request,
        received,
        sent,
    };
    let verdict = state.tf.admit(arrival, gravity, timeout, now);
    settle(node, endpoints, state, verdict).await;
    // A flood of requests ahead of the timer in the loop's order must not keep those waiting
    // from their answers.
    if state.tf.next_wake().is_some_and(|at| at <= Instant::now()) {
        due(node, endpoints, state).await;
    }
}

/// A pose candidate's or pose set's object filled from `objects_file` where it names a mesh
/// resource in it and gives no mass or friction (docs/node.md#objects): before TF and before
/// the recording, so that the request is recorded, and replays, with the mass it was answered
/// with.
fn fill(request: &mut Request, table: &ObjectTable) {
    match request {
        Request::Pose(p, _) => {
            table.fill(&mut p.object);
        }
        Request::Set(s, _) => {
            s.fill(table);
        }
        Request::Candidate(_) => {}
    }
}

/// The waiting requests whose transforms came or whose deadline passed: answered or refused.
pub(super) async fn due(node: &Node, endpoints: &Endpoints, state: &mut Loop<'_>) {
    for verdict in state.tf.ready(Instant::now()) {
        settle(node, endpoints, state, verdict).await;
    }
}

/// Sleeps until `at`; never ends for `None`.
pub(super) async fn at(at: Option<Instant>) {
    match at {
        Some(at) => {
            smol::Timer::at(at).await;
        }
        None => futures::future::pending().await,
    }
}

/// Keeps a message of `/tf` (`is_static` false) or `/tf_static`; one that does not decode is
/// skipped (the buffer's own checks drop what tf2 would not keep).
pub(super) fn keep(
    tf: &mut TfWait,
    received: Result<(TfMessage, MessageInfo), impl std::fmt::Debug>,
    is_static: bool,
) {
    match received {
        Ok((message, _)) => {
            tf.buffer.insert_message(&message, is_static);
            tf.arrived(Instant::now());
            log::debug!(
                "TF: {} transforms in (static: {is_static}); {} frames known, {} dropped",
                message.transforms.len(),
                tf.buffer.frame_count(),
                tf.buffer.dropped().total()
            );
        }
        Err(e) => log::debug!("a TF message that does not decode: {e:?}"),
    }
}

/// On a stop request: those still waiting for transforms are refused, saying so; then what the
/// buffer held and dropped, when it dropped any.
pub(super) async fn finish(node: &Node, endpoints: &Endpoints, state: &mut Loop<'_>) {
    for verdict in state.tf.drain_all() {
        settle(node, endpoints, state, verdict).await;
    }
    let b = &state.tf.buffer;
    let d = b.dropped();
    if d.total() > 0 {
        let line = format!(
            "TF: {} frames and {} samples kept; {} transforms dropped ({} for their frames, {} \
             for their values, {} older than the cache, {} past the limits)",
            b.frame_count(),
            b.sample_count(),
            d.total(),
            d.bad_frame,
            d.bad_value,
            d.too_old,
            d.over_cap
        );
        say(node, log::Level::Warn, &line);
    }
}

/// Acts on a verdict: a request ready goes on its kind's path, a refused one is answered with
/// status 2.
async fn settle(node: &Node, endpoints: &Endpoints, state: &mut Loop<'_>, verdict: Verdict) {
    match verdict {
        Verdict::Ready(arrival) => dispatch(node, endpoints, state, arrival).await,
        Verdict::Refused(arrival, why) => refuse(node, endpoints, state, arrival, &why).await,
        Verdict::Waits => {}
    }
}

/// A request that needs nothing more, answered on its kind's usual path.
async fn dispatch(node: &Node, endpoints: &Endpoints, state: &mut Loop<'_>, arrival: Arrival) {
    let Arrival {
        request,
        received,
        sent,
    } = arrival;
    let (sets, markers) = (&endpoints.sets, &endpoints.markers);
    match request {
        Request::Candidate(c) => {
            answer_one(node, endpoints, state.answerer, *c, (received, sent)).await;
        }
        Request::Pose(p, tool_frame) => {
            let loading = &mut *state.loading;
            take_pose(
                node,
                endpoints,
                state.answerer,
                loading,
                (*p, tool_frame),
                (received, sent),
            )
            .await;
        }
        Request::Set(set, Via::Topic { .. }) => {
            let (answerer, worker) = (&mut *state.answerer, &*state.worker);
            sets::take_topic(node, sets, markers, answerer, worker, set, (received, sent)).await;
        }
        Request::Set(set, via) => {
            let (answerer, worker) = (&mut *state.answerer, &*state.worker);
            sets::take_call(node, sets, markers, answerer, worker, (via, set), received).await;
        }
    }
}

/// A request refused with status 2, `invalid input: {why}`, through its kind's
/// [`Answer::refused`]; counted and recorded as it came, with its refusal.
pub(super) async fn refuse(
    node: &Node,
    endpoints: &Endpoints,
    state: &mut Loop<'_>,
    arrival: Arrival,
    why: &str,
) {
    let Arrival {
        request,
        received,
        sent,
    } = arrival;
    let with = state.answerer.answering_at(received);
    let answerer = &mut *state.answerer;
    match request {
        Request::Candidate(c) => {
            let reply = Candidates::refused(&with, &c, why);
            let outcome = answerer.account_candidate(*c, reply, received, sent);
            let answers = &endpoints.candidates.answers;
            send_answer(node, endpoints, answerer, answers, outcome).await;
        }
        Request::Pose(p, _) => {
            let reply = Poses::refused(&with, &p, why);
            let outcome = answerer.account_pose(*p, reply, None, received, sent);
            let answers = &endpoints.poses.answers;
            send_answer(node, endpoints, answerer, answers, outcome).await;
        }
        Request::Set(set, via) => {
            let reply = set.refused(&with, why);
            let (record, record_markers) = answerer.records_sets();
            let job = SetJob {
                set,
                received,
                sent,
                via,
                record,
                record_markers,
                audience: false,
            };
            let done = done_at_once(job, reply);
            sets::answer_done(node, &endpoints.sets, &endpoints.markers, answerer, done).await;
        }
    }
}
