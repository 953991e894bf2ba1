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

/// `ROS_AUTOMATIC_DISCOVERY_RANGE`: how far the node looks for others (Jazzy's rcl and
/// rmw_fastrtps; docs/node.md, "Several hosts").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DiscoveryRange {
    /// No other participant, not even on this host.
    Off,
    /// This host, and the static peers: no multicast.
    Localhost,
    /// Multicast, and the static peers (the default).
    Subnet,
    /// RustDDS's own settings; the static peers are ignored.
    SystemDefault,
}

impl DiscoveryRange {
    /// The environment's spelling.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Off => "OFF",
            Self::Localhost => "LOCALHOST",
            Self::Subnet => "SUBNET",
            Self::SystemDefault => "SYSTEM_DEFAULT",
        }
    }

    /// A value of `ROS_AUTOMATIC_DISCOVERY_RANGE` (any case); unset or empty is SUBNET.
    fn parse(value: Option<&str>) -> anyhow::Result<Self> {
        let Some(v) = value.map(str::trim).filter(|v| !v.is_empty()) else {
            return Ok(Self::Subnet);
        };
        [
            Self::Off,
            Self::Localhost,
            Self::Subnet,
            Self::SystemDefault,
        ]
        .into_iter()
        .find(|r| v.eq_ignore_ascii_case(r.name()))
        .with_context(|| {
            format!(
                "ROS_AUTOMATIC_DISCOVERY_RANGE={v:?} is not a discovery range \
                     (OFF, LOCALHOST, SUBNET or SYSTEM_DEFAULT)"
            )
        })
    }

    /// How many participant ids are probed at each static peer: what rmw_fastrtps gives Fast
    /// DDS (32 for LOCALHOST, else its default `maxInitialPeersRange` of 4).
    fn participant_ids(self) -> u16 {
        match self {
            Self::Localhost => 32,
            _ => 4,
        }
    }
}

/// The most static peers the node takes (each costs SPDP datagrams every announcement).
const MAX_STATIC_PEERS: usize = 64;

/// How this process takes part in the DDS graph.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Graph {
    /// `ROS_DOMAIN_ID`.
    pub(crate) domain_id: u16,
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE`, or LOCALHOST by the deprecated `ROS_LOCALHOST_ONLY=1`.
    pub(crate) range: DiscoveryRange,
    /// `ROS_STATIC_PEERS` resolved, when the range uses them.
    peers: StaticPeers,
}

/// The static peers' IPv4 addresses, in a fixed array so that a [`Graph`] stays `Copy`.
#[derive(Debug, Clone, Copy)]
struct StaticPeers {
    addrs: [std::net::Ipv4Addr; MAX_STATIC_PEERS],
    len: usize,
}

impl StaticPeers {
    const NONE: Self = Self {
        addrs: [std::net::Ipv4Addr::UNSPECIFIED; MAX_STATIC_PEERS],
        len: 0,
    };

    fn as_slice(&self) -> &[std::net::Ipv4Addr] {
        &self.addrs[..self.len]
    }

    /// `ROS_STATIC_PEERS`: addresses or host names separated by `;` (blanks around them and
    /// empty entries ignored), each resolved to its first IPv4 address, as rmw_fastrtps does.
    fn parse(value: Option<&str>) -> anyhow::Result<Self> {
        Self::parse_with(value, resolve_ipv4)
    }

    /// [`Self::parse`] with the name resolution given.
    fn parse_with(
        value: Option<&str>,
        resolve: impl Fn(&str) -> Option<std::net::Ipv4Addr>,
    ) -> anyhow::Result<Self> {
        let mut peers = Self::NONE;
        for entry in value.unwrap_or("").split(';').map(str::trim) {
            if entry.is_empty() {
                continue;
            }
            if peers.len == MAX_STATIC_PEERS {
                bail!("ROS_STATIC_PEERS names more than {MAX_STATIC_PEERS} peers");
            }
            let ip = resolve(entry).with_context(|| {
                format!("ROS_STATIC_PEERS: {entry:?} does not resolve to an IPv4 address")
            })?;
            peers.addrs[peers.len] = ip;
            peers.len += 1;
        }
        Ok(peers)
    }
}

/// The first IPv4 address of `host` (an address, or a name the system resolves).
fn resolve_ipv4(host: &str) -> Option<std::net::Ipv4Addr> {
    use std::net::ToSocketAddrs as _;
    let mut addrs = (host, 0).to_socket_addrs().ok()?;
    addrs.find_map(|a| match a.ip() {
        std::net::IpAddr::V4(ip) => Some(ip),
        std::net::IpAddr::V6(_) => None,
    })
}

impl Graph {
    /// `ROS_DOMAIN_ID` (0 when unset), `ROS_AUTOMATIC_DISCOVERY_RANGE` and `ROS_STATIC_PEERS`
    /// as Jazzy's rcl reads them; `ROS_LOCALHOST_ONLY=1` (deprecated) means LOCALHOST without
    /// static peers. A bad value is an error, where rcl would warn and assume LOCALHOST.
    pub(crate) fn from_env() -> anyhow::Result<Self> {
        let var = |name| std::env::var(name).ok();
        let domain_id = match var("ROS_DOMAIN_ID") {
            Some(s) if !s.trim().is_empty() => match s.trim().parse::<u16>() {
                Ok(id) if id <= 232 => id,
                _ => bail!("ROS_DOMAIN_ID={s:?} is not a domain id (0..=232)"),
            },
            _ => 0,
        };
        let localhost_only = var("ROS_LOCALHOST_ONLY").filter(|v| !v.is_empty());
        let range = DiscoveryRange::parse(var("ROS_AUTOMATIC_DISCOVERY_RANGE").as_deref())?;
        let peers = StaticPeers::parse(var("ROS_STATIC_PEERS").as_deref())?;
        Ok(Self::resolve(
            domain_id,
            localhost_only.as_deref(),
            range,
            peers,
        ))
    }

    /// `domain_id` on this host alone, with no static peers: for tests of the node's endpoints in
    /// one process.
    #[cfg(test)]
    pub(crate) fn localhost(domain_id: u16) -> Self {
        Self {
            domain_id,
            range: DiscoveryRange::Localhost,
            peers: StaticPeers::NONE,
        }
    }

    /// The range and peers in force, with rcl's warnings.
    fn resolve(
        domain_id: u16,
        localhost_only: Option<&str>,
        range: DiscoveryRange,
        peers: StaticPeers,
    ) -> Self {
        if localhost_only.is_some_and(|v| v.starts_with('1')) {
            log::warn!(
                "ROS_LOCALHOST_ONLY is deprecated: discovery range LOCALHOST, \
                 ROS_AUTOMATIC_DISCOVERY_RANGE and ROS_STATIC_PEERS ignored"
            );
            return Self {
                domain_id,
                range: DiscoveryRange::Localhost,
                peers: StaticPeers::NONE,
            };
        }
        let used = matches!(range, DiscoveryRange::Localhost | DiscoveryRange::Subnet);
        if peers.len > 0 && !used {
            log::warn!("discovery range {}: ROS_STATIC_PEERS ignored", range.name());
        }
        Self {
            domain_id,
            range,
            peers: if used { peers } else { StaticPeers::NONE },
        }
    }

    /// The static peers in force.
    pub(crate) fn static_peers(&self) -> &[std::net::Ipv4Addr] {
        self.peers.as_slice()
    }

    /// The DDS participant for this range, as rmw_fastrtps configures Fast DDS: LOCALHOST
    /// sends discovery to this host's and the static peers' discovery ports and uses no
    /// multicast (with no static peer, it also announces loopback addresses only); SUBNET
    /// adds the static peers to multicast; OFF discovers no one.
    fn participant_builder(&self) -> DomainParticipantBuilder {
        use std::net::{IpAddr, Ipv4Addr};
        let builder = DomainParticipantBuilder::new(self.domain_id);
        let peers = self.static_peers().iter().copied().map(IpAddr::V4);
        match self.range {
            DiscoveryRange::Off => builder
                .with_only_networks([Ipv4Addr::LOCALHOST])
                .multicast_discovery(false)
                .same_host_loopback(false)
                .discover_other_participants(false),
            DiscoveryRange::Localhost => {
                let builder = builder.multicast_discovery(false).with_initial_peers(
                    peers.chain([IpAddr::V4(Ipv4Addr::LOCALHOST)]),
                    self.range.participant_ids(),
                );
                if self.static_peers().is_empty() {
                    builder.with_only_networks([Ipv4Addr::LOCALHOST])
                } else {
                    builder
                }
            }
            DiscoveryRange::Subnet => {
                builder.with_initial_peers(peers, self.range.participant_ids())
            }
            DiscoveryRange::SystemDefault => builder,
        }
    }

    fn context(&self) -> anyhow::Result<Context> {
        let participant = self
            .participant_builder()
            .build()
            .context("cannot start DDS")?;
        Context::from_domain_participant(participant).context("cannot start the ROS context")
    }

    /// The discovery range and static peers when they are not the default, for log lines.
    pub(crate) fn scope(&self) -> String {
        let peers: Vec<String> = self.static_peers().iter().map(|p| p.to_string()).collect();
        match (self.range, peers.is_empty()) {
            (DiscoveryRange::Subnet, true) => String::new(),
            (range, true) => format!(" (discovery range {})", range.name()),
            (range, false) => format!(
                " (discovery range {}, static peers {})",
                range.name(),
                peers.join(";")
            ),
        }
    }
}

/// SIGINT and SIGTERM, caught from the start of a command (or never, for a helper participant).
#[derive(Debug)]
pub(crate) struct Shutdown(Option<Signals>);

impl Shutdown {
    /// Waits for a request to stop; the signal's name.
    pub(crate) async fn requested(&mut self) -> &'static str {
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
pub(crate) struct Start {
    shutdown: Shutdown,
    /// The ROS arguments.
    pub(crate) ros: RosArgs,
}

impl Start {
    /// Catches SIGINT and SIGTERM first (a signal during start-up must still end the command
    /// cleanly), then reads the ROS arguments (`--log-level` is the binary's: it sets up the
    /// logger before any command runs).
    pub(crate) fn new(ros_argv: &[String]) -> anyhow::Result<Self> {
        let signals = Signals::new([Signal::Int, Signal::Term]).context("cannot catch signals")?;
        let ros = RosArgs::parse(ros_argv)?;
        Ok(Self {
            shutdown: Shutdown(Some(signals)),
            ros,
        })
    }

    /// The node name: `-r __node:=NAME`, else `default`.
    pub(crate) fn node_name(&self, default: &str) -> String {
        self.ros
            .node_name
            .clone()
            .unwrap_or_else(|| default.to_string())
    }

    /// Joins the graph as node `name` in the namespace of `-r __ns:=`, and watches it for
    /// another node of the same full name ([`Session::watch_namesakes`]).
    pub(crate) fn open(self, name: &str, options: NodeOptions) -> anyhow::Result<Session> {
        let graph = Graph::from_env()?;
        let namespace = self.ros.namespace();
        let mut session = Session::open(graph, &namespace, name, options, self.shutdown, self.ros)?;
        session.watch_namesakes();
        Ok(session)
    }
}

/// One DDS participant with one node and its spinner.
pub(crate) struct Session {
    /// The domain and its scope.
    pub(crate) graph: Graph,
    /// The ROS arguments (empty for a helper participant).
    pub(crate) ros: RosArgs,
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
    pub(crate) fn open_helper(
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
    pub(crate) fn watch_namesakes(&mut self) {
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
    pub(crate) fn node(&self) -> &Node {
        &self.node
    }

    /// The node, to create endpoints.
    pub(crate) fn node_mut(&mut self) -> &mut Node {
        &mut self.node
    }

    /// The absolute name of topic `base` after namespace and remapping.
    pub(crate) fn topic_name(&self, base: &str) -> String {
        self.ros.topic(base, &self.name)
    }

    /// Runs `body` on this session's executor (the spinner runs beside it) until it ends.
    pub(crate) fn run<T>(&mut self, body: impl AsyncFnOnce(&mut Node, &mut Shutdown) -> T) -> T {
        smol::block_on(self.executor.run(body(&mut self.node, &mut self.shutdown)))
    }

    /// Leaves the graph in order: the node (which stops the spinner), the spinner task, and
    /// last the context, whose drop disposes the DDS participant. Endpoints must be dropped
    /// before.
    pub(crate) fn close(self) {
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
pub(crate) fn create_topic<M: RosMessage>(
    node: &Node,
    full_name: &str,
    qos: &QosProfile,
) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
    let parsed = Name::parse(full_name).map_err(|e| anyhow::anyhow!("topic {full_name}: {e:?}"))?;
    node.create_topic(&parsed, message_type_name::<M>(), qos)
        .with_context(|| format!("cannot create topic {full_name}"))
}

/// Reliable, volatile, keep-last `depth`: what rclpy's default publisher and subscription offer.
pub(crate) fn qos(depth: i64) -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast {
        depth: usize::try_from(depth.max(1)).unwrap_or(1),
    })
}

/// Logs to stderr and to `/rosout`.
pub(crate) fn say(node: &Node, level: log::Level, text: &str) {
    log::log!(target: "grasp_orient::node", level, "{text}");
    let level = match level {
        log::Level::Error => LogLevel::Error,
        log::Level::Warn => LogLevel::Warn,
        log::Level::Info => LogLevel::Info,
        log::Level::Debug | log::Level::Trace => LogLevel::Debug,
    };
    rosout!(*node, level, "{}", text);
}

/// When a message was received and when it was sent, ns since the epoch: the DDS timestamps
/// when present (received: now otherwise; sent: when received otherwise).
pub(crate) fn message_times(info: &ros2_client::MessageInfo) -> (u64, u64) {
    let received = info
        .received_timestamp()
        .map_or_else(crate::record::now_ns, |t| {
            u64::try_from(t.to_nanos()).unwrap_or(0)
        });
    let sent = info.source_timestamp().map_or(received, |t| {
        u64::try_from(t.to_nanos()).unwrap_or(received)
    });
    (received, sent)
}

/// Logs each note to stderr and `/rosout`.
pub(crate) fn tell(node: &Node, notes: Vec<(log::Level, String)>) {
    for (level, text) in notes {
        say(node, level, &text);
    }
}

#[cfg(test)]
mod tests {
    use super::{DiscoveryRange, Graph, StaticPeers};
    use std::net::Ipv4Addr;

    #[test]
    fn discovery_range_reads_as_rcl_does_and_refuses_the_rest() {
        assert_eq!(
            DiscoveryRange::parse(None).ok(),
            Some(DiscoveryRange::Subnet)
        );
        assert_eq!(
            DiscoveryRange::parse(Some("")).ok(),
            Some(DiscoveryRange::Subnet)
        );
        for range in [
            DiscoveryRange::Off,
            DiscoveryRange::Localhost,
            DiscoveryRange::Subnet,
            DiscoveryRange::SystemDefault,
        ] {
            assert_eq!(DiscoveryRange::parse(Some(range.name())).ok(), Some(range));
        }
        assert_eq!(
            DiscoveryRange::parse(Some("localhost")).ok(),
            Some(DiscoveryRange::Localhost)
        );
        let e = DiscoveryRange::parse(Some("LAN")).expect_err("LAN is no range");
        assert_eq!(
            e.to_string(),
            "ROS_AUTOMATIC_DISCOVERY_RANGE=\"LAN\" is not a discovery range \
             (OFF, LOCALHOST, SUBNET or SYSTEM_DEFAULT)"
        );
    }

    #[test]
    fn static_peers_split_on_semicolons_and_resolve_to_ipv4() {
        // An address needs no resolver; a name goes to the one given (no DNS in a test).
        assert_eq!(
            super::resolve_ipv4("10.213.0.2"),
            Some(Ipv4Addr::new(10, 213, 0, 2))
        );
        let hosts = |name: &str| match name {
            "peer-b" => Some(Ipv4Addr::new(10, 213, 0, 2)),
            _ => name.parse().ok(),
        };
        let peers = StaticPeers::parse_with(Some(" 10.213.0.1;;peer-b; 192.0.2.7 ;"), hosts)
            .expect("peers");
        assert_eq!(
            peers.as_slice(),
            [
                Ipv4Addr::new(10, 213, 0, 1),
                Ipv4Addr::new(10, 213, 0, 2),
                Ipv4Addr::new(192, 0, 2, 7)
            ]
        );
        assert!(StaticPeers::parse(None)
            .expect("none")
            .as_slice()
            .is_empty());
        let e = StaticPeers::parse_with(Some("10.213.0.2;peer-c"), hosts).expect_err("bad");
        assert!(e.to_string().contains("\"peer-c\""), "{e}");
        let many = vec!["127.0.0.1"; 65].join(";");
        assert!(StaticPeers::parse_with(Some(&many), hosts).is_err());
    }

    #[test]
    fn static_peers_count_in_localhost_and_subnet_only() {
        let peers = StaticPeers::parse(Some("10.213.0.2")).expect("peers");
        for (range, used) in [
            (DiscoveryRange::Off, false),
            (DiscoveryRange::Localhost, true),
            (DiscoveryRange::Subnet, true),
            (DiscoveryRange::SystemDefault, false),
        ] {
            let graph = Graph::resolve(0, None, range, peers);
            assert_eq!(graph.range, range);
            assert_eq!(!graph.static_peers().is_empty(), used, "{range:?}");
        }
        // ROS_LOCALHOST_ONLY=1 wins over the range and drops the peers; 0 changes nothing.
        let graph = Graph::resolve(0, Some("1"), DiscoveryRange::Subnet, peers);
        assert_eq!(graph.range, DiscoveryRange::Localhost);
        assert!(graph.static_peers().is_empty());
        let graph = Graph::resolve(0, Some("0"), DiscoveryRange::Subnet, peers);
        assert_eq!(graph.range, DiscoveryRange::Subnet);
        assert_eq!(graph.static_peers(), [Ipv4Addr::new(10, 213, 0, 2)]);
        assert_eq!(
            graph.scope(),
            " (discovery range SUBNET, static peers 10.213.0.2)"
        );
    }
}
