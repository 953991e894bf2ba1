"""The node and an rclpy peer on two hosts: two network namespaces joined by a veth pair (10.213.0.1/24 for
the node, .2 for the peer; the addresses exist only inside the namespaces), the node in one, the peer
(tests/ros/hosts_peer.py) in the other. Candidates, a set and the service `~/recommend` are answered across
them once with multicast discovery, and once with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and
ROS_STATIC_PEERS naming the other side (Jazzy's set-up for networks without multicast). Then a lossy link:
5% of the packets into the node's namespace dropped at random (nftables), runs of 205 candidates at 500/s:
every answer arrives, every run ends within 2 s of its last candidate; the figures are printed.
And a recording played over the lossy link with `grasp_orient play` arrives whole, 30 runs of 335 candidates at
about 1,000 a second. Also: a node with the range OFF is found by no one; and on the lossless link, sets of 1,000 candidates
(248 kB each, DATA_FRAGs from Fast DDS) cross into the node once and their answers out of it once, counted in
bytes by nftables on the veth against the sets' and answers' CDR sizes (RustDDS patch 0009).

Needs root (CI runs as root), iproute2 and nftables (tests/peer/setup.sh installs them). A namespace that
cannot be made fails the test, never skips it. Each test removes its namespaces (and with them the veth
pair and the nftables rules) even when it fails, and stops the processes it started.
"""
from __future__ import annotations

import concurrent.futures
import contextlib
import ctypes
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import mcap_util as mu
from conftest import DOMAIN_ID, NodeProcess, require_environment, ros_env, run_python

HERE = Path(__file__).resolve().parent
PEER = HERE / "hosts_peer.py"
NODE_IP, PEER_IP = "10.213.0.1", "10.213.0.2"
CLONE_NEWNET = 0x40000000
LOSS_RUNS = 20
LOSS_N = 205
LOSS_LIMIT_S = 2.0
LOSS_INTERVAL_S = 0.002  # 500 candidates/s: the node keeps up with it on a lossless link


def tool(name: str) -> str:
    path = shutil.which(name) or next((p for p in (f"/usr/sbin/{name}", f"/sbin/{name}") if os.path.exists(p)), None)
    if path is None:
        pytest.fail(f"{name} not found: run tests/peer/setup.sh (it installs iproute2 and nftables)", pytrace=False)
    return path


def sh(*cmd: str):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=30)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {r.returncode}: {r.stderr.strip()}")


def enter(netns: str):
    """A preexec_fn that moves the child into network namespace `netns` (setns on /run/netns/NAME)."""
    def move():
        libc = ctypes.CDLL(None, use_errno=True)
        fd = os.open(f"/run/netns/{netns}", os.O_RDONLY)
        if libc.setns(fd, CLONE_NEWNET) != 0:
            raise OSError(ctypes.get_errno(), f"setns into {netns}")
        os.close(fd)
    return move


@contextlib.contextmanager
def two_hosts(tag: str):
    """Namespaces (node, peer) joined by a veth pair, lo up, multicast routed on the veth. Removed on exit."""
    ip = tool("ip")
    node_ns, peer_ns = f"go{tag}n{os.getpid()}", f"go{tag}p{os.getpid()}"
    made: list[str] = []
    try:
        for ns in (node_ns, peer_ns):
            sh(ip, "netns", "add", ns)
            made.append(ns)
        sh(ip, "link", "add", "vgo0", "netns", node_ns, "type", "veth", "peer", "name", "vgo1", "netns", peer_ns)
        for ns, dev, addr in ((node_ns, "vgo0", NODE_IP), (peer_ns, "vgo1", PEER_IP)):
            sh(ip, "-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
            sh(ip, "-n", ns, "link", "set", "lo", "up")
            sh(ip, "-n", ns, "link", "set", dev, "up")
            sh(ip, "-n", ns, "route", "add", "224.0.0.0/4", "dev", dev)
    except (RuntimeError, OSError, subprocess.TimeoutExpired) as e:
        for ns in made:
            subprocess.run([ip, "netns", "del", ns], capture_output=True)
        pytest.fail(f"cannot make two network namespaces joined by a veth pair (root needed): {e}", pytrace=False)
    try:
        yield node_ns, peer_ns
    finally:
        for ns in made:
            subprocess.run([ip, "netns", "del", ns], capture_output=True)


def env_for(range_: str, static_peer: str | None) -> dict:
    env = ros_env(DOMAIN_ID)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = range_
    if static_peer:
        env["ROS_STATIC_PEERS"] = static_peer
    return env


@contextlib.contextmanager
def node_in(netns: str, env: dict, tmp_path: Path, args: list[str] | None = None):
    node = NodeProcess(args or [], env, tmp_path, f"grasp_orient node in {netns}", preexec_fn=enter(netns))
    try:
        node.wait_ready()
        yield node
    finally:
        try:
            node.stop_and_check()
        finally:
            node.kill()


def run_peer(netns: str, env: dict, *args: str, timeout: float, fails: bool = False) -> dict:
    r = run_python([str(PEER), *args], env, timeout=timeout, preexec_fn=enter(netns))
    lines = [l for l in r.stdout.splitlines() if l.startswith("{")]
    assert lines, f"the peer printed no result (exit {r.returncode}); stderr:\n{r.stderr[-3000:]}"
    out = json.loads(lines[-1])
    if not fails:
        assert "error" not in out, f"the peer in {netns}: {out['error']}\nstderr:\n{r.stderr[-3000:]}"
    return out


def check_graph(out: dict, n: int):
    assert out["candidates"] == n and out["answered_ids"], out
    want = [f"hosts-{k}" for k in range(5)]
    assert out["set"] == want, f"the set's answer: {out['set']}"
    assert out["service"] == want, f"the service's answer: {out['service']}"


@pytest.mark.parametrize("range_, static", [("SUBNET", False), ("LOCALHOST", True)],
                         ids=["multicast", "localhost-and-static-peers"])
def test_candidates_sets_and_the_service_across_two_hosts(range_, static, tmp_path):
    require_environment()
    with two_hosts("g" if static else "m") as (node_ns, peer_ns):
        node_env = env_for(range_, PEER_IP if static else None)
        peer_env = env_for(range_, NODE_IP if static else None)
        with node_in(node_ns, node_env, tmp_path) as node:
            if static:
                assert f"static peers {PEER_IP}" in node.output(), node.output()
            out = run_peer(peer_ns, peer_env, "graph", "--n", "20", "--timeout", "30", timeout=120)
            check_graph(out, 20)


def test_a_node_with_discovery_off_is_found_by_no_one(tmp_path):
    """ROS_AUTOMATIC_DISCOVERY_RANGE=OFF: the peer names the node as a static peer, and still nothing
    matches (Jazzy: OFF discovers no one, even a peer that found it)."""
    require_environment()
    with two_hosts("o") as (node_ns, peer_ns):
        with node_in(node_ns, env_for("OFF", PEER_IP), tmp_path) as node:
            assert "discovery range OFF" in node.output(), node.output()
            out = run_peer(peer_ns, env_for("LOCALHOST", NODE_IP), "graph", "--n", "1", "--timeout", "8",
                           timeout=60, fails=True)
    assert out.get("error", "").startswith("no match on /grasp_candidates"), out


def drop_into(netns: str, nft: str):
    """nftables in `netns`: 5% of the packets into it dropped at random."""
    ip = tool("ip")
    for rule in (["add", "table", "inet", "t"],
                 ["add", "chain", "inet", "t", "c", "{ type filter hook input priority 0; }"],
                 ["add", "rule", "inet", "t", "c", "numgen", "random", "mod", "100", "<", "5", "drop"]):
        sh(ip, "netns", "exec", netns, nft, *rule)


def quantile(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


def test_every_answer_arrives_over_a_lossy_link(tmp_path):
    """5% of the packets into the node's namespace are dropped; LOSS_RUNS runs of LOSS_N candidates, one every
    LOSS_INTERVAL_S. Every answer arrives (before RustDDS patch 0008 some never did), and every run ends
    within LOSS_LIMIT_S of its last candidate. Before 0008 almost none did: a lost candidate waited for the
    writer's next HEARTBEAT, every 3 s from Fast DDS. With 0008 but not 0011, 75 of 80 runs did: when a
    run's last candidate, or the repair of a lost one, was lost, no later DATA told the node, and only the
    writer's next HEARTBEAT did (2.07 to 2.71 s). With 0011 the node's reader polls a writer that went quiet
    after DATA (50 ms after it, then 150, 350, 750 ms) and Fast DDS answers with a HEARTBEAT at once; the
    figures (printed) show the runs that needed it (a last answer some 60 to 360 ms after the last
    candidate)."""
    require_environment()
    nft = tool("nft")
    with two_hosts("l") as (node_ns, peer_ns):
        drop_into(node_ns, nft)
        env = env_for("SUBNET", None)
        with node_in(node_ns, env, tmp_path):
            out = run_peer(peer_ns, env, "burst", "--runs", str(LOSS_RUNS), "--n", str(LOSS_N),
                           "--interval", str(LOSS_INTERVAL_S), "--timeout", "10", timeout=60 + 12 * LOSS_RUNS)
    runs = out["runs"]
    trips = [t for r in runs for t in r["round_trip_s"]]
    lasts = [max((x for x in r["after_last_s"] if x is not None), default=float("nan")) for r in runs]
    late = [[k for k, x in enumerate(r["after_last_s"]) if x is not None and x > LOSS_LIMIT_S] for r in runs]
    print(f"\nlossy link (5% into the node's namespace), {len(runs)} runs of {LOSS_N} at "
          f"{1 / LOSS_INTERVAL_S:.0f}/s: answered {[r['answered'] for r in runs]}; last answer after the last "
          f"candidate (s) {[round(x, 3) for x in lasts]}; answers over {LOSS_LIMIT_S} s late (run: how many) "
          f"{ {k: len(l) for k, l in enumerate(late) if l} }; round trip p50 {quantile(trips, 0.5) * 1e3:.1f} ms, "
          f"p99 {quantile(trips, 0.99) * 1e3:.1f} ms, max {max(trips) * 1e3:.1f} ms")
    short = [(k, r["answered"]) for k, r in enumerate(runs) if r["answered"] != LOSS_N]
    assert not short, f"runs with answers missing 10 s after the last candidate (run, answered): {short}"
    over = [(k, round(x, 3)) for k, x in enumerate(lasts) if not x <= LOSS_LIMIT_S]
    assert not over, (f"runs whose last answer came over {LOSS_LIMIT_S} s after their last candidate "
                      f"(run, s): {over}")


PLAY_BAG = HERE.parents[1] / "bags" / "random_grasps.mcap"
PLAY_RUNS = 30
# 10: the bag's 335 candidates (10 ms apart as recorded) in 0.34 s, about 1,000 a second.
PLAY_RATE = 10.0
PLAY_LANES = 2
PLAY_LOGS = "info,rustdds=warn,rustdds::rtps::reader=info,rustdds::rtps::writer=info,rustdds::discovery=info," \
            "rustdds::network::udp_listener=off"


def played_candidates(recording: Path) -> list[tuple]:
    """(id, stamp) of each candidate a recording holds, in order."""
    return [(r.msg["id"], r.msg["header"]["stamp"]["sec"], r.msg["header"]["stamp"]["nanosec"])
            for r in mu.read_mcap(recording, topics=["/grasp_candidates"])]


def spans(positions: list[int]) -> str:
    """[3, 4, 5, 9] as "3-5, 9"."""
    runs: list[list[int]] = []  # [first, last] of each run of consecutive positions
    for k in positions:
        if runs and k == runs[-1][1] + 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def play_over_a_lossy_link(tmp_path: Path, runs: int, rate: float, node_args: list[str]) -> list[tuple[int, str]]:
    """`grasp_orient play` of PLAY_BAG from the peer's namespace into a fresh recording node in the node's, 5% of
    the packets into the node's namespace dropped, `runs` times at `--rate rate`. The runs whose recording misses
    candidates: (run, positions in the bag); each such run's node and play logs are left in its folder.

    The runs go PLAY_LANES at a time, each lane in a pair of namespaces of its own (a network of its own, with
    the same addresses) taking every PLAY_LANES-th run: a run mostly waits (for discovery, for play's pace, for
    its last acknowledgements), so one lane alone left the machine idle."""
    grasp = require_environment()
    want = played_candidates(PLAY_BAG)
    nft = tool("nft")

    def lane(k: int) -> list[tuple[int, str]]:
        losing: list[tuple[int, str]] = []
        with two_hosts(f"s{k}") as (node_ns, peer_ns):
            drop_into(node_ns, nft)
            env = env_for("SUBNET", None)
            env["RUST_LOG"] = PLAY_LOGS
            for run in range(k, runs, PLAY_LANES):
                cwd = tmp_path / f"run{run}"
                cwd.mkdir()
                with node_in(node_ns, env, cwd, node_args) as node:
                    r = subprocess.run([str(grasp), "play", str(PLAY_BAG), "--rate", f"{rate:g}"], env=env,
                                       capture_output=True, text=True, timeout=60, preexec_fn=enter(peer_ns),
                                       cwd=str(cwd))
                    assert r.returncode == 0, f"play in {peer_ns} exited {r.returncode}:\n{r.stderr[-3000:]}"
                recordings = sorted((cwd / "runs").glob("*.mcap"))
                assert len(recordings) == 1, recordings
                got = set(played_candidates(recordings[0]))
                missing = [i for i, w in enumerate(want) if w not in got]
                if missing:
                    where = spans(missing)
                    losing.append((run, where))
                    (cwd / "node.log").write_text("\n".join(node.all_lines()))
                    (cwd / "play.log").write_text(r.stderr)
                    print(f"run {run}: missing positions {where} of {len(want)} (logs in {cwd})")
        return losing

    with concurrent.futures.ThreadPoolExecutor(PLAY_LANES) as pool:
        lanes = [pool.submit(lane, k) for k in range(PLAY_LANES)]
        losing = sorted(x for f in lanes for x in f.result())
    print(f"\n{runs} runs of {len(want)} candidates played at {rate:g} times the recorded pace, "
          f"{PLAY_LANES} at a time, {len(losing)} with candidates missing")
    return losing


def test_a_recording_played_over_a_lossy_link_arrives_whole(tmp_path):
    """PLAY_RUNS runs of `grasp_orient play` (a RustDDS writer, where the rclpy peer above is Fast DDS) at about
    1,000 candidates a second over the lossy link: every run's recording holds every candidate. Before RustDDS
    patch 0014, 5 of 60 such runs lost candidates, 4 of them every one: play's discovery data for its writer
    was lost on the way to the node, and play's writer for discovery, idle before, announced it again only at
    its periodic HEARTBEAT a second later, after play had sent everything and ended. With 0014 it does so
    100 ms after sending it: 0 of 260 runs lost any. tests/ros/soak_play_lossy.py runs this longer."""
    losing = play_over_a_lossy_link(tmp_path, PLAY_RUNS, PLAY_RATE, [])
    assert not losing, f"runs that lost candidates (run, positions in the bag): {losing}"


WIRE_SETS = 10
WIRE_N = 1000
WIRE_RATIO = 1.2
# Per set, on top of WIRE_RATIO x its CDR size: the HEARTBEATs and ACKNACKs (tens of bytes each) of a set and its
# answer, beside the RTPS, UDP and IP headers (about 100 bytes a datagram) that the ratio already covers.
WIRE_ALLOWANCE = 8192
# nftables in the node's namespace: UDP bytes and packets through the veth, in and out, all of it and the part
# to odd ports (RTPS user traffic: port 7400 + 250 x domain + 11 + 2 x participant for unicast, + 1 for
# multicast; discovery goes to the even ones). A counter counts IP packets (IP header included) and sees a
# datagram whole: reassembled before the input hook, not yet fragmented at the output hook.
WIRE_NFT = """table inet gowire {
  counter in_all {}
  counter in_user {}
  counter out_all {}
  counter out_user {}
  chain i { type filter hook input priority 0; policy accept;
    iifname "vgo0" meta l4proto udp counter name in_all; iifname "vgo0" udp dport & 1 == 1 counter name in_user; }
  chain o { type filter hook output priority 0; policy accept;
    oifname "vgo0" meta l4proto udp counter name out_all; oifname "vgo0" udp dport & 1 == 1 counter name out_user; }
}
"""


def wire_snapshot(text: str) -> dict:
    """{counter: (packets, bytes)} from `nft -j list counters`, and UDP's RcvbufErrors in each namespace."""
    nft, node_snmp, peer_snmp = text.split("@@@")
    out = {c["counter"]["name"]: (c["counter"]["packets"], c["counter"]["bytes"])
           for c in json.loads(nft)["nftables"] if "counter" in c}
    for side, snmp in (("node", node_snmp), ("peer", peer_snmp)):
        head, values = [l.split()[1:] for l in snmp.splitlines() if l.startswith("Udp:")][:2]
        out[f"{side}_rcvbuf_errors"] = int(dict(zip(head, values))["RcvbufErrors"])
    return out


def run_wire_sets(tmp_path: Path) -> dict:
    """The node in one namespace with WIRE_NFT's counters, the peer's `sets` in the other (4 MB receive
    buffer, default send buffer: tests/ros/fastdds_large_receive_buffer.xml); the peer's output."""
    nft, ip = tool("nft"), tool("ip")
    with two_hosts("w") as (node_ns, peer_ns):
        (tmp_path / "wire.nft").write_text(WIRE_NFT)
        sh(ip, "netns", "exec", node_ns, nft, "-f", str(tmp_path / "wire.nft"))
        # Run by the peer (in its namespace) before and after the sets: the counters, and /proc/net/snmp of
        # both namespaces (`cat` runs in the peer's).
        snap = (f"{ip} netns exec {node_ns} {nft} -j list counters table inet gowire; echo @@@; "
                f"{ip} netns exec {node_ns} cat /proc/net/snmp; echo @@@; cat /proc/net/snmp")
        env = env_for("SUBNET", None)
        profile = str(HERE / "fastdds_large_receive_buffer.xml")
        peer_env = dict(env, FASTRTPS_DEFAULT_PROFILES_FILE=profile, FASTDDS_DEFAULT_PROFILES_FILE=profile)
        with node_in(node_ns, env, tmp_path):
            return run_peer(peer_ns, peer_env, "sets", "--sets", str(WIRE_SETS), "--n", str(WIRE_N),
                            "--snapshot", snap, "--timeout", "30", timeout=240)


def test_a_large_set_crosses_the_wire_once(tmp_path):
    """WIRE_SETS sets of WIRE_N candidates (248 kB of CDR each), one at a time, each answered (355 kB), over the
    lossless veth: the UDP bytes into the node's namespace per set are at most WIRE_RATIO x the set's CDR size
    plus WIRE_ALLOWANCE, and the bytes out per answer likewise. Counted by nftables on the veth, to the RTPS
    user ports only (odd ports; discovery uses the even ones), less what crossed to them in as long a time with
    no sets just after. The figures are printed. No datagram may be dropped at a socket in either namespace
    (UDP RcvbufErrors), else repairs would count: the peer has a 4 MB receive buffer.

    The peer's send buffer is the system's default: with it Fast DDS sends a HEARTBEAT announcing a set while
    the set's fragments are still on their way. A node whose reader answered it at once (before RustDDS patch
    0009, or 0009 with its response delay set to 0) asked for those fragments and they crossed again: 1.34 to
    1.48 x the set, where 1.00 to 1.10 x with the delay (a loaded machine; docs/performance.md)."""
    require_environment()
    out = run_wire_sets(tmp_path)
    before, after, idle = (wire_snapshot(s["out"]) for s in out["snapshots"])
    sets_s = out["snapshots"][1]["t"] - out["snapshots"][0]["t"]
    req, ans = out["request_bytes"], out["answer_bytes"]
    assert len(ans) == WIRE_SETS, f"{len(ans)} answers to {WIRE_SETS} sets"
    dropped = {k: after[k] - before[k] for k in ("node_rcvbuf_errors", "peer_rcvbuf_errors")}

    def per_set(name: str) -> tuple[float, float, int]:
        """Bytes per set (less the idle baseline), packets per set, and the idle bytes."""
        idle_b = idle[name][1] - after[name][1]
        b = (after[name][1] - before[name][1] - idle_b) / WIRE_SETS
        return b, (after[name][0] - before[name][0]) / WIRE_SETS, idle_b

    (in_b, in_p, in_idle), (out_b, out_p, out_idle) = per_set("in_user"), per_set("out_user")
    req_b, ans_b = sum(req) / len(req), sum(ans) / len(ans)
    in_all, out_all = per_set("in_all")[0], per_set("out_all")[0]
    print(f"\n{WIRE_SETS} sets of {WIRE_N} across the veth in {sets_s:.2f} s: set {req_b:.0f} B of CDR, "
          f"into the node {in_b:.0f} B a set in {in_p:.1f} datagrams ({in_b / req_b:.3f} x; all UDP "
          f"{in_all:.0f} B); answer {ans_b:.0f} B, out of the node {out_b:.0f} B in {out_p:.1f} datagrams "
          f"({out_b / ans_b:.3f} x; all UDP {out_all:.0f} B); idle baseline over {sets_s:.2f} s: in {in_idle} B, "
          f"out {out_idle} B; datagrams dropped at a socket {dropped}")
    assert not any(dropped.values()), f"datagrams dropped at a socket during the sets: {dropped}"
    in_limit, out_limit = WIRE_RATIO * req_b + WIRE_ALLOWANCE, WIRE_RATIO * ans_b + WIRE_ALLOWANCE
    assert in_b <= in_limit, (f"{in_b:.0f} B crossed into the node per set of {req_b:.0f} B "
                              f"({in_b / req_b:.2f} x; at most {in_limit:.0f}): fragments sent more than once")
    assert out_b <= out_limit, (f"{out_b:.0f} B crossed out of the node per answer of {ans_b:.0f} B "
                                f"({out_b / ans_b:.2f} x; at most {out_limit:.0f}): fragments sent more than once")
