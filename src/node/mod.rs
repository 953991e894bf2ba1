//! The ROS 2 node: subscribes `grasp_candidates`, answers on `grip_recommendations` and
//! `grip_markers`, with parameters, rosout, remapping and a clean exit on Ctrl-C and SIGTERM.
//! Built on ros2-client (RustDDS), which reads neither `ROS_DOMAIN_ID` nor `--ros-args`: both
//! are handled here.

pub mod markers;
mod params;
pub mod play;
pub mod ros_args;

use crate::config::Config;
use crate::msg::{answer, GraspCandidate, GripRecommendation, MarkerArray};
use crate::record::{now_ns, Entry, Payload, Recorder, Topics};
use anyhow::{bail, Context as _};
use async_signal::{Signal, Signals};
use futures::{FutureExt, StreamExt};
use params::Shared;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::qos::History;
use ros2_client::ros2::LogLevel;
use ros2_client::{
    rosout, Context, MessageTypeName, Name, Node, NodeName, NodeOptions, QosProfile,
};
use ros_args::RosArgs;
use std::pin::pin;
use std::time::{Duration, Instant};

/// Default node name.
pub const NODE_NAME: &str = "grasp_orient";
/// The paper's four case studies, sent by `--demo`.
const PAPER_CASES: &str = include_str!("../../examples/paper_cases.jsonl");

/// Arguments of `node` (ROS arguments come separately, after `--ros-args`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct Args {
    /// Also send the paper's four case studies to the node over DDS, print the answers, and exit.
    #[arg(long)]
    pub demo: bool,
    /// Benchmark floor: answer every candidate with an empty recommendation (same header and id)
    /// without solving.
    #[arg(long)]
    pub echo: bool,
}

/// How this process takes part in the DDS graph.
#[derive(Debug, Clone, Copy)]
struct Graph {
    domain_id: u16,
    localhost_only: bool,
}

impl Graph {
    /// `ROS_DOMAIN_ID` (0 when unset), and `ROS_LOCALHOST_ONLY=1` or
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` to keep to loopback.
    fn from_env() -> anyhow::Result<Self> {
        let domain_id = match std::env::var("ROS_DOMAIN_ID") {
            Ok(s) if !s.trim().is_empty() => match s.trim().parse::<u16>() {
                Ok(id) if id <= 232 => id,
                _ => bail!("ROS_DOMAIN_ID={s:?} is not a domain id (0..=232)"),
            },
            _ => 0,
        };
        let localhost_only = std::env::var("ROS_LOCALHOST_ONLY").is_ok_and(|v| v == "1")
            || std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE")
                .is_ok_and(|v| v.eq_ignore_ascii_case("localhost"));
        Ok(Self {
            domain_id,
            localhost_only,
        })
    }

    fn context(&self) -> anyhow::Result<Context> {
        let mut builder = DomainParticipantBuilder::new(self.domain_id);
        if self.localhost_only {
            builder = builder.with_only_networks([std::net::Ipv4Addr::LOCALHOST]);
        }
        let participant = builder.build().context("cannot start DDS")?;
        Context::from_domain_participant(participant).context("cannot start the ROS context")
    }
}

/// Reads the settings: the built-in defaults, then each `--params-file`, then each `-p`.
fn load_config(ros: &RosArgs, node: &str) -> anyhow::Result<(Config, crate::solver::Settings)> {
    let mut config = Config::load(None, node)?;
    for path in &ros.params_files {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read --params-file {}", path.display()))?;
        config.merge_yaml(&text, &path.display().to_string(), node)?;
    }
    for (name, value) in &ros.params {
        if !config.parameters().iter().any(|(n, _)| n == name) {
            bail!("-p {name}:={value}: grasp_orient has no parameter {name}");
        }
        config
            .set_from_yaml(name, value)
            .with_context(|| format!("-p {name}:={value}"))?;
    }
    let settings = config.validate()?;
    Ok((config, settings))
}

/// Creates the topic `full_name` (absolute) of type `package/msg/kind`.
fn create_topic(
    node: &Node,
    full_name: &str,
    package: &str,
    kind: &str,
    qos: &QosProfile,
) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
    let parsed = Name::parse(full_name).map_err(|e| anyhow::anyhow!("topic {full_name}: {e:?}"))?;
    node.create_topic(&parsed, MessageTypeName::new(package, kind), qos)
        .with_context(|| format!("cannot create topic {full_name}"))
}

fn qos(depth: i64) -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast {
        depth: usize::try_from(depth.max(1)).unwrap_or(1),
    })
}

/// Logs to stderr and to `/rosout`.
fn say(node: &Node, level: LogLevel, text: &str) {
    match level {
        LogLevel::Error | LogLevel::Fatal => log::error!("{text}"),
        LogLevel::Warn => log::warn!("{text}"),
        LogLevel::Debug => log::debug!("{text}"),
        _ => log::info!("{text}"),
    }
    rosout!(*node, level, "{}", text);
}

/// What the node has done, for its last words and the demo.
#[derive(Debug, Default)]
struct Counts {
    answered: u64,
    invalid: u64,
    no_closure: u64,
    undecodable: u64,
}

/// Runs the node until Ctrl-C or SIGTERM (or until the demo is done).
pub fn run(args: &Args, ros_argv: &[String]) -> anyhow::Result<()> {
    // First thing: a signal during start-up must still end the node cleanly.
    let mut signals = Signals::new([Signal::Int, Signal::Term]).context("cannot catch signals")?;
    let ros = RosArgs::parse(ros_argv)?;
    if let Some(level) = &ros.log_level {
        let filter = level
            .parse()
            .with_context(|| format!("--log-level {level}"))?;
        log::set_max_level(filter);
    }
    let name = ros
        .node_name
        .clone()
        .unwrap_or_else(|| NODE_NAME.to_string());
    let namespace = ros.namespace();
    let (config, settings) = load_config(&ros, &name)?;
    let graph = Graph::from_env()?;
    let context = graph.context()?;

    let shared = Shared::new(config.clone(), settings);
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true)
        .parameter_validator(shared.validator())
        .parameter_set_action(shared.set_action());
    for (param, value) in config.parameters() {
        if let Some(v) = params::from_yaml(&value) {
            options = options.declare_parameter(&param, v);
        }
    }
    let mut node = context
        .new_node(
            NodeName::new(&namespace, &name).context("invalid node name or namespace")?,
            options,
        )
        .context("cannot create the node")?;

    let qos = qos(config.qos_depth);
    let topic = |node: &Node, base: &str, package: &str, kind: &str| {
        let full = ros.topic(base, &name);
        create_topic(node, &full, package, kind, &qos).map(|t| (t, full))
    };
    let (candidates_topic, candidates_name) =
        topic(&node, "grasp_candidates", "grasp_orient", "GraspCandidate")?;
    let (answers_topic, answers_name) = topic(
        &node,
        "grip_recommendations",
        "grasp_orient",
        "GripRecommendation",
    )?;
    let (markers_topic, markers_name) =
        topic(&node, "grip_markers", "visualization_msgs", "MarkerArray")?;
    let subscription = node
        .create_subscription::<GraspCandidate>(&candidates_topic, None)
        .context("cannot subscribe")?;
    let answers = node
        .create_publisher::<GripRecommendation>(&answers_topic, None)
        .context("cannot publish recommendations")?;
    let marker_publisher = node
        .create_publisher::<MarkerArray>(&markers_topic, None)
        .context("cannot publish markers")?;

    let executor = smol::Executor::new();
    let spinner = executor.spawn(node.spinner().context("cannot start the spinner")?.spin());
    let fqn = node.fully_qualified_name();
    say(
        &node,
        LogLevel::Info,
        &format!(
            "node {fqn} on ROS_DOMAIN_ID={}{}: waiting for grasp_orient/msg/GraspCandidate on \
             {candidates_name}; answers on {answers_name}, markers on {markers_name}. \
             Send a test grasp with: python3 examples/publish_test_grasp.py",
            graph.domain_id,
            if graph.localhost_only {
                " (localhost only)"
            } else {
                ""
            }
        ),
    );
    let topics = Topics {
        candidates: candidates_name.clone(),
        recommendations: answers_name.clone(),
        markers: Some(markers_name.clone()),
    };
    let mut recording = Recording::new(topics, config.qos_depth);
    if !args.echo {
        recording.follow(&node, &config)?;
    }
    if args.echo {
        say(
            &node,
            LogLevel::Warn,
            "echo mode: answers are empty, nothing is solved",
        );
    }

    let (demo_done_tx, demo_done_rx) = smol::channel::bounded::<anyhow::Result<()>>(1);
    let demo = args.demo.then(|| {
        let (c, a) = (candidates_name.clone(), answers_name.clone());
        executor.spawn(async move {
            let result = run_demo(&graph, &c, &a).await;
            let _ = demo_done_tx.send(result).await;
        })
    });

    let mut counts = Counts::default();
    let echo = args.echo;
    let outcome = smol::block_on(executor.run(async {
        let mut stream = pin!(subscription.async_stream());
        // Without --demo the sender is gone at once: a closed channel then means "never".
        let mut demo_done = pin!(async {
            match demo_done_rx.recv().await {
                Ok(result) => result,
                Err(_) => futures::future::pending().await,
            }
        }
        .fuse());
        let outcome: anyhow::Result<()> = loop {
            futures::select! {
                signal = signals.next().fuse() => {
                    let name = match signal {
                        Some(Ok(Signal::Term)) => "SIGTERM",
                        _ => "SIGINT",
                    };
                    say(&node, LogLevel::Info, &format!("{name}: leaving the ROS graph"));
                    break Ok(());
                }
                result = demo_done => break result,
                received = stream.select_next_some() => match received {
                    Ok((candidate, info)) => {
                        let received = info
                            .received_timestamp()
                            .map_or_else(now_ns, |t| u64::try_from(t.to_nanos()).unwrap_or(0));
                        let sent = info
                            .source_timestamp()
                            .map_or(received, |t| u64::try_from(t.to_nanos()).unwrap_or(received));
                        let (settings, markers_on, record) = {
                            let live = shared.lock();
                            (live.settings, live.config.publish_markers, live.config.record)
                        };
                        if !echo && recording.must_follow(record) {
                            let config = shared.lock().config.clone();
                            if let Err(e) = recording.follow(&node, &config) {
                                say(&node, LogLevel::Error, &format!("{e:#}"));
                            }
                        }
                        let reply = if echo {
                            GripRecommendation {
                                header: candidate.header.clone(),
                                candidate_id: candidate.id.clone(),
                                ..GripRecommendation::default()
                            }
                        } else {
                            answer(&candidate, &settings)
                        };
                        match reply.status {
                            GripRecommendation::STATUS_OK => {}
                            GripRecommendation::STATUS_NO_FORCE_CLOSURE => counts.no_closure += 1,
                            _ => {
                                counts.invalid += 1;
                                say(&node, LogLevel::Warn, &format!(
                                    "candidate {:?}: {} ({} refused so far)",
                                    truncate(&reply.candidate_id), reply.message, counts.invalid));
                            }
                        }
                        counts.answered += 1;
                        // The answer goes out first; markers and the recording follow it.
                        let recorded_reply = recording.is_on().then(|| reply.clone());
                        let array = (markers_on && !echo && reply.status == GripRecommendation::STATUS_OK)
                            .then(|| markers::build(&candidate, &reply));
                        if let Err(e) = answers.async_publish(reply).await {
                            say(&node, LogLevel::Error, &format!("cannot publish an answer: {e:?}"));
                        }
                        let t = now_ns();
                        if let Some(array) = array {
                            if recording.records_markers() {
                                recording.record(Payload::Markers(Box::new(array.clone())), t, t);
                            }
                            if let Err(e) = marker_publisher.async_publish(array).await {
                                log::warn!("cannot publish markers: {e:?}");
                            }
                        }
                        recording.record(Payload::Candidate(Box::new(candidate)), received, sent);
                        if let Some(r) = recorded_reply {
                            recording.record(Payload::Recommendation(Box::new(r)), t, t);
                        }
                    }
                    Err(e) => {
                        counts.undecodable += 1;
                        say(&node, LogLevel::Warn, &format!(
                            "a message on {candidates_name} could not be decoded ({e:?}); {} so far",
                            counts.undecodable));
                    }
                },
            }
        };
        say(&node, LogLevel::Info, &format!(
            "answered {} candidates: {} refused as invalid, {} without force closure, {} undecodable",
            counts.answered, counts.invalid, counts.no_closure, counts.undecodable));
        recording.stop(&node);
        outcome
    }));
    // Leave the graph in order: endpoints, the node (stops the spinner), the spinner task, the
    // demo, and last the context, whose drop disposes the DDS participant.
    drop(subscription);
    drop(answers);
    drop(marker_publisher);
    drop(node);
    smol::block_on(executor.run(async {
        if let Err(e) = spinner.await {
            log::warn!("the spinner ended with an error: {e:?}");
        }
        if let Some(d) = demo {
            d.cancel().await;
        }
    }));
    drop(executor);
    drop(context);
    outcome
}

/// The node's recording: started, stopped and restarted as the `record` parameter says.
struct Recording {
    topics: Topics,
    qos_depth: i64,
    active: Option<Recorder>,
    /// Whether the active recording has a markers channel (fixed when it starts).
    markers: bool,
    /// Whether a start failed for the current settings (not retried for every candidate).
    failed: bool,
}

impl Recording {
    fn new(topics: Topics, qos_depth: i64) -> Self {
        Self {
            topics,
            qos_depth,
            active: None,
            markers: false,
            failed: false,
        }
    }

    /// Whether `record` asks for a start or a stop (a failed start is not retried until
    /// `record` goes false).
    fn must_follow(&self, record: bool) -> bool {
        match (self.active.is_some(), record) {
            (false, true) => !self.failed,
            (true, false) => true,
            (false, false) => self.failed,
            (true, true) => false,
        }
    }

    /// Starts or stops recording to match `config.record`.
    fn follow(&mut self, node: &Node, config: &Config) -> anyhow::Result<()> {
        match (&self.active, config.record) {
            (None, true) if !self.failed => {
                let topics = Topics {
                    markers: config
                        .record_markers
                        .then(|| self.topics.markers.clone())
                        .flatten(),
                    ..self.topics.clone()
                };
                match Recorder::start(
                    std::path::Path::new(&config.record_dir),
                    topics,
                    self.qos_depth,
                ) {
                    Ok(r) => {
                        say(
                            node,
                            LogLevel::Info,
                            &format!("recording to {}", r.path().display()),
                        );
                        self.markers = config.record_markers;
                        self.active = Some(r);
                    }
                    Err(e) => {
                        self.failed = true;
                        return Err(anyhow::Error::new(e).context("recording is off"));
                    }
                }
            }
            (Some(_), false) => self.stop(node),
            (None, false) => self.failed = false,
            _ => {}
        }
        Ok(())
    }

    fn is_on(&self) -> bool {
        self.active.is_some()
    }

    fn records_markers(&self) -> bool {
        self.is_on() && self.markers
    }

    fn record(&self, payload: Payload, log_time: u64, publish_time: u64) {
        if let Some(r) = &self.active {
            if !r.record(Entry {
                payload,
                log_time,
                publish_time,
            }) {
                log::error!(
                    "the recording {} stopped; see its error",
                    r.path().display()
                );
            }
        }
    }

    /// Finishes the file and says what it holds.
    fn stop(&mut self, node: &Node) {
        if let Some(r) = self.active.take() {
            let path = r.path().to_path_buf();
            match r.finish() {
                Ok(w) => say(
                    node,
                    LogLevel::Info,
                    &format!(
                        "recording {} closed: {} candidates, {} recommendations, {} marker arrays",
                        path.display(),
                        w.candidates,
                        w.recommendations,
                        w.markers
                    ),
                ),
                Err(e) => say(node, LogLevel::Error, &format!("recording failed: {e}")),
            }
        }
    }
}

fn truncate(id: &str) -> String {
    id.chars().take(64).collect()
}

/// `--demo`: a second participant sends the paper's four cases and prints the answers.
async fn run_demo(graph: &Graph, candidates: &str, answers: &str) -> anyhow::Result<()> {
    let context = graph.context()?;
    let mut node = context
        .new_node(
            NodeName::new("/", "grasp_orient_demo").context("demo node name")?,
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .context("cannot create the demo node")?;
    let qos = qos(100);
    let topic_in = create_topic(&node, candidates, "grasp_orient", "GraspCandidate", &qos)?;
    let topic_out = create_topic(&node, answers, "grasp_orient", "GripRecommendation", &qos)?;
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
    println!("The paper's four case studies (Ito et al., Table 1), answered over DDS by {candidates} -> {answers}:");
    println!(
        "{:<9} {:>6} {:>15} {:>10} {:>14} {:>16} {:>6}",
        "case", "status", "wrist rotation", "(deg)", "squeeze [N]", "grip power [N]", "label"
    );
    for reply in got.into_iter().flatten() {
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
    Ok(())
}
