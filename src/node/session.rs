//! A process's session in the ROS graph, shared by `node`, `play` and `--demo`: the domain from
//! the environment, the DDS context, one node with its spinner, SIGINT and SIGTERM, and the
//! teardown in the order that leaves the graph cleanly. ros2-client reads neither
//! `ROS_DOMAIN_ID` nor `--ros-args`; both are handled here.
//!
//! ```text
//! Start::new(argv)   signals caught first, --ros-args read
//!   .open(..)        context on ROS_DOMAIN_ID, the node, its spinner        -> Session
//! session.run(..)    the command's work, with the node and the shutdown request
//! session.close()    node (stops the spinner), the spinner task, last the context
//! ```

use super::ros_args::RosArgs;
use crate::msg::{message_type_name, RosMessage};
use anyhow::{bail, Context as _};
use async_signal::{Signal, Signals};
use futures::StreamExt;
use ros2_client::dds::rustdds::{DomainParticipantBuilder, RTPSEntity as _};
use ros2_client::gid::Gid;
use ros2_client::qos::History;
use ros2_client::ros2::LogLevel;
use ros2_client::{rosout, Context, Name, Node, NodeEvent, NodeName, NodeOptions, QosProfile};

/// How this process takes part in the DDS graph.
#[derive(Debug, Clone, Copy)]
pub struct Graph {
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u16,
    /// Discovery and traffic on loopback only.
    pub localhost_only: bool,
}

impl Graph {
    /// `ROS_DOMAIN_ID` (0 when unset), and `ROS_LOCALHOST_ONLY=1` or
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` to keep to loopback.
    pub fn from_env() -> anyhow::Result<Self> {
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

    /// ` (localhost only)` when it is, for log lines.
    pub fn scope(&self) -> &'static str {
        if self.localhost_only {
            " (localhost only)"
        } else {
            ""
        }
    }
}

/// SIGINT and SIGTERM, caught from the start of a command (or never, for a helper participant).
#[derive(Debug)]
pub struct Shutdown(Option<Signals>);

impl Shutdown {
    /// Waits for a request to stop; the signal's name.
    pub async fn requested(&mut self) -> &'static str {
        let Some(signals) = self.0.as_mut() else {
            return futures::future::pending().await;
        };
        match signals.next().await {
            Some(Ok(Signal::Term)) => "SIGTERM",
            _ => "SIGINT",
        }
    }
}

/// A command before it joins the graph: signals caught, `--ros-args` read.
#[derive(Debug)]
pub struct Start {
    shutdown: Shutdown,
    /// The ROS arguments.
    pub ros: RosArgs,
}

impl Start {
    /// Catches SIGINT and SIGTERM first (a signal during start-up must still end the command
    /// cleanly), then reads the ROS arguments (`--log-level` is the binary's: it sets up the
    /// logger before any command runs).
    pub fn new(ros_argv: &[String]) -> anyhow::Result<Self> {
        let signals = Signals::new([Signal::Int, Signal::Term]).context("cannot catch signals")?;
        let ros = RosArgs::parse(ros_argv)?;
        Ok(Self {
            shutdown: Shutdown(Some(signals)),
            ros,
        })
    }

    /// The node name: `-r __node:=NAME`, else `default`.
    pub fn node_name(&self, default: &str) -> String {
        self.ros
            .node_name
            .clone()
            .unwrap_or_else(|| default.to_string())
    }

    /// Joins the graph as node `name` in the namespace of `-r __ns:=`, and watches it for
    /// another node of the same full name ([`Session::watch_namesakes`]).
    pub fn open(self, name: &str, options: NodeOptions) -> anyhow::Result<Session> {
        let graph = Graph::from_env()?;
        let namespace = self.ros.namespace();
        let mut session = Session::open(graph, &namespace, name, options, self.shutdown, self.ros)?;
        session.watch_namesakes();
        Ok(session)
    }
}

/// One DDS participant with one node and its spinner.
pub struct Session {
    /// The domain and its scope.
    pub graph: Graph,
    /// The ROS arguments (empty for a helper participant).
    pub ros: RosArgs,
    name: String,
    shutdown: Shutdown,
    // Fields drop in this order when a session is dropped without `close` (a command refused
    // after joining the graph): the node first, while its spinner can still hear the request to
    // stop; before, the spinner went first and ros2-client logged "Cannot notify spin task to
    // stop" above the refusal.
    node: Node,
    executor: smol::Executor<'static>,
    spinner: smol::Task<Result<(), ros2_client::CreateError>>,
    /// The watch for another node of the same name, while it runs.
    namesakes: Option<smol::Task<()>>,
    context: Context,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field("graph", &self.graph)
            .field("node", &self.node.fully_qualified_name())
            .finish_non_exhaustive()
    }
}

impl Session {
    /// A helper participant (no signals, no ROS arguments), as `--demo` uses.
    pub fn open_helper(
        graph: Graph,
        namespace: &str,
        name: &str,
        options: NodeOptions,
    ) -> anyhow::Result<Self> {
        Self::open(
            graph,
            namespace,
            name,
            options,
            Shutdown(None),
            RosArgs::default(),
        )
    }

    fn open(
        graph: Graph,
        namespace: &str,
        name: &str,
        options: NodeOptions,
        shutdown: Shutdown,
        ros: RosArgs,
    ) -> anyhow::Result<Self> {
        let context = graph.context()?;
        let mut node = context
            .new_node(
                NodeName::new(namespace, name).context("invalid node name or namespace")?,
                options,
            )
            .context("cannot create the node")?;
        let executor = smol::Executor::new();
        let spinner = executor.spawn(node.spinner().context("cannot start the spinner")?.spin());
        Ok(Self {
            graph,
            ros,
            name: name.to_string(),
            shutdown,
            executor,
            spinner,
            namesakes: None,
            node,
            context,
        })
    }

    /// Warns once for each other DDS participant that holds a node of this node's full name, as
    /// it appears in `ros_discovery_info` (whoever started first: that topic keeps each
    /// participant's last list for those who join later). rcl only warns of a namesake in its
    /// own process; two nodes of one name on a domain share their parameter services, their
    /// `/rosout` logger and their line in `ros2 node list`.
    pub fn watch_namesakes(&mut self) {
        let Some(events) = self.node.status_receiver() else {
            return;
        };
        let own = Gid::from(self.context.domain_participant().guid());
        let name = self.node.fully_qualified_name();
        let logger = self.node.logging_handle();
        self.namesakes = Some(self.executor.spawn(async move {
            let mut warned = std::collections::BTreeSet::new();
            while let Ok(event) = events.recv().await {
                let NodeEvent::ParticipantEntities(info) = event else {
                    continue;
                };
                let namesake = info
                    .nodes()
                    .iter()
                    .any(|n| n.fully_qualified_name() == name);
                if info.gid() != own && namesake && warned.insert(info.gid()) {
                    let text = namesake_warning(&name, info.gid());
                    log::warn!(target: "grasp_orient::node", "{text}");
                    rosout!(logger, LogLevel::Warn, "{}", text);
                }
            }
        }));
    }

    /// The node.
    pub fn node(&self) -> &Node {
        &self.node
    }

    /// The node, to create endpoints.
    pub fn node_mut(&mut self) -> &mut Node {
        &mut self.node
    }

    /// The absolute name of topic `base` after namespace and remapping.
    pub fn topic_name(&self, base: &str) -> String {
        self.ros.topic(base, &self.name)
    }

    /// Runs `body` on this session's executor (the spinner runs beside it) until it ends.
    pub fn run<T>(&mut self, body: impl AsyncFnOnce(&mut Node, &mut Shutdown) -> T) -> T {
        smol::block_on(self.executor.run(body(&mut self.node, &mut self.shutdown)))
    }

    /// Leaves the graph in order: the node (which stops the spinner), the spinner task, and
    /// last the context, whose drop disposes the DDS participant. Endpoints must be dropped
    /// before.
    pub fn close(self) {
        let Session {
            executor,
            spinner,
            namesakes,
            node,
            context,
            ..
        } = self;
        drop(namesakes);
        drop(node);
        smol::block_on(executor.run(async {
            if let Err(e) = spinner.await {
                log::warn!("the spinner ended with an error: {e:?}");
            }
        }));
        drop(executor);
        drop(context);
    }
}

/// The warning for another node named `name` in DDS participant `gid`, with the caution
/// `ros2 node list` prints for names that are shared.
fn namesake_warning(name: &str, gid: Gid) -> String {
    format!(
        "another node named {name} is on the ROS graph (DDS participant {gid:?}). Be aware that \
         nodes that share an exact name can have unintended side effects: their parameter \
         services, /rosout logger name and entry in `ros2 node list` are shared. Give this one \
         another name with --ros-args -r __node:=NAME"
    )
}

/// Creates the topic `full_name` (absolute) carrying messages of type `M`.
pub fn create_topic<M: RosMessage>(
    node: &Node,
    full_name: &str,
    qos: &QosProfile,
) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
    let parsed = Name::parse(full_name).map_err(|e| anyhow::anyhow!("topic {full_name}: {e:?}"))?;
    node.create_topic(&parsed, message_type_name::<M>(), qos)
        .with_context(|| format!("cannot create topic {full_name}"))
}

/// Reliable, volatile, keep-last `depth`: what rclpy's default publisher and subscription offer.
pub fn qos(depth: i64) -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast {
        depth: usize::try_from(depth.max(1)).unwrap_or(1),
    })
}

/// Logs to stderr and to `/rosout`.
pub fn say(node: &Node, level: log::Level, text: &str) {
    log::log!(target: "grasp_orient::node", level, "{text}");
    let level = match level {
        log::Level::Error => LogLevel::Error,
        log::Level::Warn => LogLevel::Warn,
        log::Level::Info => LogLevel::Info,
        log::Level::Debug | log::Level::Trace => LogLevel::Debug,
    };
    rosout!(*node, level, "{}", text);
}
