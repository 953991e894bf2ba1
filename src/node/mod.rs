//! The ROS 2 node: subscribes `grasp_candidates`, answers on `grip_recommendations` and
//! `grip_markers`; answers sets on `grasp_candidate_sets` → `grip_recommendation_sets` and through
//! the service `~/recommend` ([`sets`]); gripper poses on `pose_candidates` →
//! `pose_recommendations`, their sets on `pose_candidate_sets` → `pose_recommendation_sets` and
//! through `~/recommend_poses`; an answer's grip force sent to the gripper's action through
//! `~/grip` ([`grip`]); with parameters, rosout, remapping and a clean exit on Ctrl-C and SIGTERM.
//!
//! [`run`] reads the settings, opens the [`session::Session`], creates the endpoints and the
//! parameter services, and then only moves messages: each candidate goes to
//! [`answer::Answerer::handle`], and what that returns is published and recorded. Sets go to the
//! set thread ([`set_worker`]), so that however long a set takes, the node's thread keeps
//! answering single candidates, parameter requests and signals; their answers are published as
//! they come back.

pub(crate) mod answer;
pub(crate) mod demo;
mod endpoint;
mod grip;
mod intake;
pub(crate) mod loads;

mod grasps;
mod markers_out;
mod moveit_in;
mod param_services;
mod params;
pub(crate) mod play;
pub(crate) mod pose_work;
mod proxy;
mod requests;
pub(crate) mod ros_args;
mod scene;
pub(crate) mod session;
pub(crate) mod set_io;
mod set_kinds;
pub(crate) mod set_worker;
pub(crate) mod sets;
mod tf;
mod tf_serve;
mod tf_wait;

use crate::config::Config;
use crate::kind::{Candidates, PoseSets, Poses, Sets};
use crate::record::{now_ns, OnStop, Topics};
use answer::Answerer;
use anyhow::Context as _;
use demo::Demo;
use futures::{FutureExt, StreamExt};
use intake::OffThread;
use loads::{Loaders, PoseLoads};
use param_services::ParameterServices;
use params::Shared;
use requests::{send_loaded, Endpoints, Loading, Loop};
use ros2_client::{Node, NodeOptions};
use ros_args::RosArgs;
use session::{message_times, say, tell, Session, Shutdown, Start};
use set_worker::{SetWorker, Via};
use std::pin::pin;
use std::time::Duration;
use tf_wait::{Request, TfWait};

/// After a stop request, how long the node waits for the answers of the sets it holds (the one
/// being solved stops between two candidates; those waiting are answered unsolved) before it
/// leaves without them: well within the second a supervisor gives between SIGTERM and SIGKILL.
const STOP_GRACE: Duration = Duration::from_millis(300);

/// Default node name.
pub(crate) const NODE_NAME: &str = "grasp_orient";

/// The node's topics, as it names them before namespace and remapping (checked to stay apart
/// before any DDS entity is made).
const TOPICS: [&str; 9] = [
    "grasp_candidates",
    "grip_recommendations",
    "grip_markers",
    "grasp_candidate_sets",
    "grip_recommendation_sets",
    "pose_candidates",
    "pose_recommendations",
    "pose_candidate_sets",
    "pose_recommendation_sets",
];

/// What else the node does besides answering.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Options {
    /// Send the paper's four case studies from a second participant, print the answers, exit.
    pub(crate) demo: bool,
    /// Benchmark floor: answer every candidate with an empty recommendation (same header and
    /// id) without solving.
    pub(crate) echo: bool,
}

/// Reads the settings: the built-in defaults, then each `--params-file`, then each `-p`.
fn load_config(ros: &RosArgs, node: &str) -> anyhow::Result<(Config, crate::solver::Settings)> {
    let mut config = Config::load(None, node)?;
    for path in &ros.params_files {
        let text = crate::config::read_text(path, crate::config::MAX_FILE_BYTES)
            .map_err(|source| crate::config::ConfigError::Read {
                path: path.display().to_string(),
                source,
            })
            .context("--params-file")?;
        let sections = config.merge_yaml(&text, &path.display().to_string(), node)?;
        if sections.applied.is_empty() {
            // rcl skips such a file without a word (one file may serve several nodes); a line
            // saves a user who misspelt the node's name.
            log::warn!(
                "--params-file {}: no section applies to node {node} (found: {}); its settings \
                 are not used",
                path.display(),
                sections.found.join(", ")
            );
        }
    }
    for (name, value) in &ros.params {
        if crate::config::Parameter::find(name).is_none() {
            let unknown = crate::config::ConfigError::Unknown { name: name.clone() };
            return Err(anyhow::Error::new(unknown).context(format!("-p {name}:={value}")));
        }
        config
            .set_from_yaml(name, value)
            .with_context(|| format!("-p {name}:={value}"))?;
    }
    let settings = config.solver_settings()?;
    // The gripper's and the planner's actions are refused here, before the node joins the graph.
    grip::action_name(&config, |name| ros.topic(name, node))?;
    proxy::planner_name(&config, |name| ros.topic(name, node))?;
    Ok((config, settings))
}

/// The mass and friction of named objects, from `objects_file` (read once, at start).
fn objects_table(config: &Config) -> anyhow::Result<crate::config::objects::ObjectTable> {
    let objects = crate::config::objects::ObjectTable::load(&config.objects_file)
        .map_err(anyhow::Error::msg)?;
    if objects.len() > 0 {
        log::info!("objects_file: {} objects and meshes", objects.len());
    }
    Ok(objects)
}

/// Runs the node until Ctrl-C or SIGTERM (or until the demo is done).
pub(crate) fn run(options: Options, ros_argv: &[String]) -> anyhow::Result<()> {
    let start = Start::new(ros_argv)?;
    let name = start.node_name(NODE_NAME);
    start.ros.check_distinct(&TOPICS, &name)?;
    let (config, settings) = load_config(&start.ros, &name)?;
    let objects = objects_table(&config)?;
    // Inline meshes are decoded no further than the node would answer them (later values too:
    // `Live::push`).
    crate::msg::limit_inline_mesh_decoding(config.max_inline_mesh_triangles);
    log::debug!("settings: {config:?}");
    let shared = Shared::new(config.clone(), settings);
    let node_options = shared.declare(
        NodeOptions::new()
            .enable_rosout(true)
            .start_parameter_services(false),
    );
    let max_message_bytes = usize::try_from(config.max_message_bytes).unwrap_or(usize::MAX);
    let mut session = start.open_bounded(&name, node_options, max_message_bytes)?;
    let endpoints = Endpoints::create(&mut session, config.qos_depth)?;
    let services = ParameterServices::offer(session.node_mut(), &shared)?;
    let topics = &endpoints.topics;
    announce(&session, topics);
    let (on_stop, mut woken) = wake_on_change(&shared);
    // One mesh cache for the node: its thread (single pose candidates) and the set thread.
    let meshes = std::sync::Arc::new(node_meshes(&config));
    // The loader threads, for the node's thread and the set thread together.
    let loaders = Loaders::new(loads::MAX_LOADERS);
    let mut worker = SetWorker::start(
        shared.clone(),
        options.echo,
        meshes.clone(),
        loaders.clone(),
    )
    .context("cannot start the set thread")?;
    let for_grip = shared.clone();
    let mut answerer = Answerer::new(
        shared,
        options.echo,
        &session.node().fully_qualified_name(),
        topics.clone(),
        config.qos_depth,
        on_stop,
        meshes,
    );
    let (grip, proxy, mut relays) = offer_actions(&mut session, &config, &for_grip, &answerer)?;
    let started = answerer
        .start()
        .map_err(|e| anyhow::Error::new(e).context("recording is off"))?;
    tell(session.node(), started);
    let demo = options.demo.then(|| {
        Demo::start(
            session.graph,
            topics
                .requests::<Candidates>()
                .unwrap_or_default()
                .to_string(),
            topics
                .answers::<Candidates>()
                .unwrap_or_default()
                .to_string(),
        )
    });
    let outcome = session.run(async |node, shutdown| {
        let node = &*node;
        // The parameter services run as a task of their own, woken only by their requests.
        let local = smol::LocalExecutor::new();
        let _services = local.spawn(services.serve(node));
        let _markers_watch = local.spawn(endpoints.markers.watch(node));
        let _grip = local.spawn(grip.serve(node));
        let _proxy = proxy.as_ref().map(|p| local.spawn(p.serve(node)));
        let mut loading = PoseLoads::new(loaders);
        let mut tf = TfWait::new();
        let mut scene = scene::Scene::new(objects);
        let mut loop_state = Loop {
            answerer: &mut answerer,
            worker: &mut worker,
            woken: &mut woken,
            loading: &mut loading,
            tf: &mut tf,
            scene: &mut scene,
        };
        let outcome = local
            .run(serve(
                node,
                shutdown,
                &endpoints,
                &mut loop_state,
                &mut relays,
                demo.as_ref(),
            ))
            .await;
        tf_serve::finish(node, &endpoints, &mut loop_state).await;
        finish_sets(node, &endpoints, &mut answerer, &mut worker).await;
        finish_loads(node, &endpoints, &mut answerer, &mut loading).await;
        tell(node, answerer.finish());
        outcome
    });
    // Leave the graph in order: the set thread (not waited for inside a long candidate),
    // endpoints and services, the demo's participant, then the session (node, spinner, context).
    drop(worker);
    drop(endpoints);
    drop(services);
    drop((grip, proxy));
    if let Some(demo) = demo {
        demo.stop();
    }
    session.close();
    outcome
}

/// `~/grip` with the gripper's action client, and the grasp planner proxy with the stream of
/// the objects it hands to the node's thread.
fn offer_actions(
    session: &mut Session,
    config: &Config,
    shared: &Shared,
    answerer: &Answerer,
) -> anyhow::Result<(grip::Grip, Option<proxy::Proxy>, proxy::Relays)> {
    let grip = grip::Grip::offer(session, config, shared, answerer.recent())?;
    let (proxy, relays) = proxy::Proxy::offer(session, config, shared)?;
    Ok((grip, proxy, relays))
}

/// The first line a user reads: where the node listens and answers, and how to try it.
fn announce(session: &Session, topics: &Topics) {
    say(
        session.node(),
        log::Level::Info,
        &format!(
            "node {} on ROS_DOMAIN_ID={}{}: waiting for grasp_orient/msg/GraspCandidate on \
             {}; answers on {}, markers on {}; sets on {} -> {} and the service {}/{}; \
             gripper poses on {} -> {}, their sets on {} -> {} and the service {}/{}; \
             MoveIt's grasps through the service {}/{} on the objects of {} and {}. \
             Send a test grasp with: python3 examples/publish_test_grasp.py",
            session.node().fully_qualified_name(),
            session.graph.domain_id,
            session.graph.scope(),
            topics.requests::<Candidates>().unwrap_or_default(),
            topics.answers::<Candidates>().unwrap_or_default(),
            topics.markers.as_deref().unwrap_or_default(),
            topics.requests::<Sets>().unwrap_or_default(),
            topics.answers::<Sets>().unwrap_or_default(),
            session.node().fully_qualified_name(),
            <Sets as sets::NodeSet>::SERVICE,
            topics.requests::<Poses>().unwrap_or_default(),
            topics.answers::<Poses>().unwrap_or_default(),
            topics.requests::<PoseSets>().unwrap_or_default(),
            topics.answers::<PoseSets>().unwrap_or_default(),
            session.node().fully_qualified_name(),
            <PoseSets as sets::NodeSet>::SERVICE,
            session.node().fully_qualified_name(),
            grasps::SERVICE,
            session.topic_name(scene::COLLISION_OBJECT_TOPIC),
            session.topic_name(scene::PLANNING_SCENE_TOPIC),
        ),
    );
}

/// Parameter sets and a recording writer that stops both wake the answering loop, so that each
/// takes effect at once rather than at the next candidate: the callback for the writer, and what
/// the loop waits on.
fn wake_on_change(shared: &Shared) -> (OnStop, futures::channel::mpsc::UnboundedReceiver<()>) {
    let (wake, woken) = futures::channel::mpsc::unbounded::<()>();
    let on_stop = {
        let wake = wake.clone();
        std::sync::Arc::new(move || {
            wake.unbounded_send(()).ok();
        })
    };
    shared.wake_on_change(move || {
        wake.unbounded_send(()).ok();
    });
    (on_stop, woken)
}

/// Answers every candidate until a signal, or until the demo is done; acts on parameter sets
/// and on a recording that stopped as soon as `woken` says so. Every request goes through
/// [`tf_serve::admit`] (turned by TF, or waiting for its transforms); sets are handed to the set
/// thread and their answers sent as they come back.
async fn serve(
    node: &Node,
    shutdown: &mut Shutdown,
    endpoints: &Endpoints,
    state: &mut Loop<'_>,
    relays: &mut proxy::Relays,
    demo: Option<&Demo>,
) -> anyhow::Result<()> {
    let mut stream = pin!(endpoints.candidates.requests.async_stream());
    // Pose candidates and sets may carry inline meshes: decoded on threads of their own.
    let mut poses = OffThread::spawn(
        "grasp_orient poses",
        endpoints.poses.requests.clone(),
        |s| s.async_stream().boxed_local(),
    )?;
    let sets_in = (endpoints.sets.clone(), endpoints.topics.clone());
    let mut arrivals = OffThread::spawn("grasp_orient sets", sets_in, |(s, t)| {
        sets::arrivals(s, t).boxed_local()
    })?;
    let mut tf_dynamic = pin!(endpoints.tf.dynamic.async_stream());
    let mut tf_static = pin!(endpoints.tf.fixed.async_stream());
    let mut objects = pin!(endpoints.moveit.objects.async_stream());
    let mut scenes = pin!(endpoints.moveit.scenes.async_stream());
    let mut demo_done = pin!(async {
        match demo {
            Some(d) => d.finished().await,
            None => futures::future::pending().await,
        }
    }
    .fuse());
    let (sets, markers, topics) = (&endpoints.sets, &endpoints.markers, &endpoints.topics);
    loop {
        // Biased, in this order: a stop request wins over whatever is queued, then the demo's
        // end, then a parameter set or a stopped writer (so that it applies to every candidate
        // still queued), then the requests waiting for transforms that are due, then
        // candidates, then sets' answers back from the set thread, then pose candidates, then
        // new sets of any kind (one stream, taken in turn), then transforms (each request drains
        // those already in before it is looked at); each costs the node's thread microseconds to
        // milliseconds (a set is solved on the set thread), so a signal is seen within one.
        let wake = state.tf.next_wake();
        futures::select_biased! {
            signal = shutdown.requested().fuse() => {
                say(node, log::Level::Info, &format!("{signal}: leaving the ROS graph"));
                return Ok(());
            }
            result = demo_done => return result,
            () = state.woken.select_next_some() => tell(node, state.answerer.refresh()),
            () = tf_serve::at(wake).fuse() => tf_serve::due(node, endpoints, state).await,
            received = stream.select_next_some() => match received {
                Ok((candidate, info)) => {
                    let request = Request::Candidate(Box::new(candidate));
                    tf_serve::admit(node, endpoints, state, request, message_times(&info)).await;
                }
                Err(e) => tell(node, vec![state.answerer.undecodable(topics.requests::<Candidates>().unwrap_or_default(), &e)]),
            },
            loaded = state.loading.next().fuse() => send_loaded(node, endpoints, state.answerer, loaded).await,
            done = state.worker.done.select_next_some() => {
                sets::answer_done(node, sets, markers, state.answerer, done).await;
            }
            received = poses.select_next_some() => match received {
                Ok((candidate, info)) => {
                    let request = Request::Pose(Box::new(candidate), None);
                    tf_serve::admit(node, endpoints, state, request, message_times(&info)).await;
                }
                Err(e) => {
                    let topic = topics.requests::<Poses>().unwrap_or_default();
                    let note = state.answerer.undecodable(topic, &e);
                    tell(node, vec![note]);
                }
            },
            arrival = arrivals.select_next_some() => match arrival {
                sets::Arrival::Topic(set, info) => {
                    let request = Request::Set(set, Via::Topic { taken: Duration::ZERO });
                    tf_serve::admit(node, endpoints, state, request, message_times(&info)).await;
                }
                sets::Arrival::Call(id, set) => {
                    let now = now_ns();
                    tf_serve::admit(node, endpoints, state, Request::Set(set, Via::Service(id)), (now, now)).await;
                }
                sets::Arrival::Grasps(id, call) => {
                    let caller = grasps::Caller::Service(id);
                    moveit_in::take_call(node, endpoints, state, caller, *call).await;
                }
                sets::Arrival::Undecodable(topic, why) => {
                    tell(node, vec![state.answerer.undecodable(&topic, &why)]);
                }
            },
            relay = relays.select_next_some() => proxy::take(node, endpoints, state, relay).await,
            received = tf_static.select_next_some() => tf_serve::keep(state.tf, received, true),
            received = objects.select_next_some() => moveit_in::learn_object(node, state, received),
            received = scenes.select_next_some() => moveit_in::learn_scene(node, state, received),
            received = tf_dynamic.select_next_some() => tf_serve::keep(state.tf, received, false),
        }
    }
}

/// On a stop request: stops the set thread and, for at most [`STOP_GRACE`], sends the answers of
/// the sets it still holds (each cut where its solving stopped), so that a caller gets an answer
/// and the recording holds it.
async fn finish_sets(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    worker: &mut SetWorker,
) {
    worker.stop();
    let mut grace = FutureExt::fuse(smol::Timer::after(STOP_GRACE));
    loop {
        futures::select_biased! {
            done = worker.done.next() => match done {
                Some(done) => {
                    let markers = &endpoints.markers;
                    sets::answer_done(node, &endpoints.sets, markers, answerer, done).await;
                }
                None => return,
            },
            _ = grace => {
                if !worker.ended() {
                    say(
                        node,
                        log::Level::Warn,
                        "a set's candidate was still being solved; leaving without its answer",
                    );
                }
                return;
            }
        }
    }
}

/// On a stop request: for at most [`STOP_GRACE`], sends the answers of the pose candidates still
/// loading their meshes.
async fn finish_loads(
    node: &Node,
    endpoints: &Endpoints,
    answerer: &mut Answerer,
    loading: &mut Loading,
) {
    for l in loading.drain_queued() {
        send_loaded(node, endpoints, answerer, l).await;
    }
    let mut grace = FutureExt::fuse(smol::Timer::after(STOP_GRACE));
    while loading.running() {
        futures::select_biased! {
            l = loading.next().fuse() => send_loaded(node, endpoints, answerer, l).await,
            _ = grace => {
                say(node, log::Level::Warn, "a pose candidate's mesh was still loading; leaving without its answer");
                return;
            }
        }
    }
}

/// The node's mesh cache: files read only under `mesh_roots` and inside packages' share
/// directories, of at most `max_mesh_file_bytes` (a peer on the domain names them).
fn node_meshes(config: &Config) -> grasp_orient_geometry::MeshCache {
    let max_file_bytes = u64::try_from(config.max_mesh_file_bytes).unwrap_or(u64::MAX);
    for root in &config.mesh_roots {
        if !std::path::Path::new(root).is_dir() {
            log::warn!("mesh_roots: {root:?} is not a directory; no mesh is read under it");
        }
    }
    grasp_orient_geometry::MeshCache::with_access(
        grasp_orient_geometry::AmentIndex::from_env(),
        grasp_orient_geometry::load::Access::confined(&config.mesh_roots)
            .with_max_file_bytes(max_file_bytes),
        crate::answer::MESH_CACHE_BYTES,
    )
}
