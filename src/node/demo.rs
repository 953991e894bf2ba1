//! `node --demo`: a second participant, in a thread and a [`Session`] of its own, sends the
//! paper's four case studies to the node over DDS, prints the answers, and tells the node it is
//! done.

use super::session::{create_topic, qos, Graph, Session};
use crate::msg::{GraspCandidate, GripRecommendation};
use anyhow::{anyhow, bail, Context as _};
use futures::{FutureExt, StreamExt};
use ros2_client::{Node, NodeOptions};
use smol::channel::{Receiver, Sender};
use std::pin::pin;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The paper's four case studies.
const PAPER_CASES: &str = include_str!("../../examples/paper_cases.jsonl");

/// The demo participant, running.
#[derive(Debug)]
pub(crate) struct Demo {
    stop: Sender<()>,
    done: Receiver<anyhow::Result<()>>,
    thread: JoinHandle<()>,
}

impl Demo {
    /// Starts sending on `candidates` and listening on `answers` (absolute topic names).
    pub(crate) fn start(graph: Graph, candidates: String, answers: String) -> Self {
        let (stop, stopped) = smol::channel::bounded(1);
        let (finished, done) = smol::channel::bounded(1);
        let thread = std::thread::spawn(move || {
            let result = run(graph, &candidates, &answers, &stopped);
            // Nobody listens any more when the node stopped first.
            finished.send_blocking(result).ok();
        });
        Self { stop, done, thread }
    }

    /// Waits until every case has been answered and printed (or the demo failed).
    pub(crate) async fn finished(&self) -> anyhow::Result<()> {
        match self.done.recv().await {
            Ok(result) => result,
            Err(_) => Err(anyhow!("the demo ended without a result")),
        }
    }

    /// Stops the demo if it still runs, and waits until its participant has left the graph.
    pub(crate) fn stop(self) {
        self.stop.close();
        if self.thread.join().is_err() {
            log::error!("the demo thread panicked");
        }
    }
}

/// The demo's own session: sends, collects, prints; or stops when asked to.
fn run(graph: Graph, candidates: &str, answers: &str, stop: &Receiver<()>) -> anyhow::Result<()> {
    let options = NodeOptions::new()
        .enable_rosout(false)
        .start_parameter_services(false);
    let mut session = Session::open_helper(graph, "/", "grasp_orient_demo", options)?;
    let result = session.run(async |node, _| {
        let mut exchange = pin!(exchange(node, candidates, answers).fuse());
        futures::select! {
            got = exchange => got.map(Some),
            _ = stop.recv().fuse() => Ok(None),
        }
    });
    session.close();
    if let Some(got) = result? {
        print(candidates, answers, &got);
    }
    Ok(())
}

/// Sends every case until each has its answer; the answers in the order of the cases.
async fn exchange(
    node: &mut Node,
    candidates: &str,
    answers: &str,
) -> anyhow::Result<Vec<GripRecommendation>> {
    let qos = qos(100);
    let topic_in = create_topic::<GraspCandidate>(node, candidates, &qos)?;
    let topic_out = create_topic::<GripRecommendation>(node, answers, &qos)?;
    let publisher = node.create_publisher::<GraspCandidate>(&topic_in, None)?;
    let replies = node.create_subscription::<GripRecommendation>(&topic_out, None)?;
    let cases: Vec<GraspCandidate> = PAPER_CASES
        .lines()
        .map(serde_json::from_str)
        .collect::<Result<_, _>>()
        .context("built-in paper cases")?;
    let mut got: Vec<Option<GripRecommendation>> = vec![None; cases.len()];
    let mut stream = pin!(replies.async_stream());
    let deadline = Instant::now() + Duration::from_secs(20);
    // Resend what is unanswered every half second until discovery has matched both ends.
    while got.iter().any(Option::is_none) {
        if Instant::now() > deadline {
            bail!("the demo got no answer within 20 s: is DDS discovery working on this host?");
        }
        for (case, answer) in cases.iter().zip(&got) {
            if answer.is_none() {
                publisher.async_publish(case.clone()).await.ok();
            }
        }
        let mut timer = pin!(FutureExt::fuse(smol::Timer::after(Duration::from_millis(
            500
        ))));
        loop {
            futures::select! {
                _ = timer => break,
                reply = stream.select_next_some() => if let Ok((reply, _)) = reply {
                    if let Some(i) = cases.iter().position(|c| c.id == reply.candidate_id) {
                        got[i] = Some(reply);
                    }
                },
            }
        }
    }
    Ok(got.into_iter().flatten().collect())
}

fn print(candidates: &str, answers: &str, got: &[GripRecommendation]) {
    println!("The paper's four case studies (Ito et al., Table 1), answered over DDS by {candidates} -> {answers}:");
    println!(
        "{:<9} {:>6} {:>15} {:>10} {:>14} {:>16} {:>6}",
        "case", "status", "wrist rotation", "(deg)", "squeeze [N]", "grip power [N]", "label"
    );
    for reply in got {
        println!(
            "{:<9} {:>6} {:>15.6} {:>10.3} {:>14.6} {:>16.6} {:>6}",
            reply.candidate_id,
            reply.status,
            reply.wrist_rotation,
            reply.wrist_rotation.to_degrees(),
            reply.internal_force,
            reply.gripping_power,
            reply.recommended_label
        );
    }
}
