#!/usr/bin/env python3
"""Benchmark of sets over ROS 2 on loopback, from rclpy (not a pytest test), in one run:

    source "$(bash tests/peer/setup.sh | tail -n1)"
    cargo build --release
    python benches/bench_sets.py --bin target/release/grasp_orient [--n 1000] [--sets 60] [--singles 300]
        [--also-bin LABEL=PATH ...] [--large-buffers]

(a) A set of --n candidates published on grasp_candidate_sets and its answer received on
    grip_recommendation_sets, one set at a time: min, p50 and p99 of the round trip, for `grasp_orient node` and for
    `grasp_orient node --echo`, which answers a set with as many empty recommendations (same header and id),
    nothing solved: the same transport and sizes, the floor. Target: node p50 <= 1.5 x echo p50.
    The set is serialized once and published as bytes, and the answer is taken as bytes (rclpy's raw
    subscription), so that Python's own (de)serialization of half a megabyte is not counted, on either side.
(b) One candidate: the service ~/recommend called with a set of 1 (`call_async`, the reply deserialized by
    rclpy), against the topic round trip of one candidate on grasp_candidates -> grip_recommendations (raw), and
    of a set of 1 on the set topics (raw): p50 and p99.
Each variant runs in a node of its own (namespace), record:=false, publish_markers:=false, so that only the
answering is measured; the echo, the node, and the node with solver_threads:=1 (one solver thread: what the
threads buy) are interleaved over --repeat repetitions and the medians printed.
(c) The set round trip of (a) again in turns: every variant's node running at once, one set sent to each in
    turn (--sets x --repeat rounds, the order turned each round), so that all are measured over the same
    minutes; its p50s, and the median over rounds of the node's round trip over the echo's and minus it. And
    where each set's time in each node went, from the node's debug line per set (src/node/sets.rs): from the
    set's arrival in its DDS reader to the start of its answer, the answer, the publishing; and after it, from
    the answer handed to DDS to its arrival in this process's callback (both on the system clock): the
    transport and rclpy's share, which grows with the answer's bytes.
--also-bin LABEL=PATH adds another binary (an older build, say), run as shipped like the node, to (a), (b)
and (c): a change measured against the build before it in the same run.
With --large-buffers, this process (the rclpy side) uses tests/ros/fastdds_large_buffers.xml: 4 MB socket
buffers instead of the system's 208 kB, which an answer of 240 to 320 kB overflows; lost fragments then wait
for the writer's next heartbeat to be repaired.

All traffic stays on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, one ROS_DOMAIN_ID for the run).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
# The pytest suite's helpers live in tests/ros: conftest (node, domain, messages) and the Fast DDS profile.
ROS_TESTS = HERE.parent / "tests" / "ros"
sys.path.insert(0, str(ROS_TESTS))

if "--large-buffers" in sys.argv:
    # Before rclpy loads Fast DDS, which reads its profiles file when it starts (2.x: FASTRTPS_, 3.x: FASTDDS_).
    for var in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
        os.environ[var] = str(ROS_TESTS / "fastdds_large_buffers.xml")

import conftest as C  # noqa: E402  (sets ROS_DOMAIN_ID and localhost discovery before rclpy)


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def percentile(xs, q):
    xs = sorted(xs)
    k = (len(xs) - 1) * q
    f = int(k)
    c = min(f + 1, len(xs) - 1)
    return xs[f] + (xs[c] - xs[f]) * (k - f)


def summary(lat: list[float]) -> dict:
    return {"n": len(lat), "min_ms": 1e3 * min(lat), "p50_ms": 1e3 * percentile(lat, 0.5),
            "p99_ms": 1e3 * percentile(lat, 0.99), "max_ms": 1e3 * max(lat)}


def candidates(n: int, seed: int, prefix: str) -> list[dict]:
    rng = random.Random(seed)
    return [C.random_grasp(rng, f"{prefix}-{k}") for k in range(n)]


def set_message(cands: list[dict], sid: str):
    from grasp_orient.msg import GraspCandidateSet

    s = GraspCandidateSet()
    s.id = sid
    s.candidates = [C.candidate_msg(c) for c in cands]
    return s


class Raw:
    """A raw subscription: counts arrivals (bytes) with their times, and the same times on the system clock
    (ns since the epoch, the clock of the node's debug lines)."""

    def __init__(self, peer, msg_type, topic: str):
        self.times: list[tuple[float, int]] = []
        self.wall_ns: list[int] = []
        self.sub = peer.node.create_subscription(msg_type, topic, self._arrived, C.reliable_qos(100), raw=True)

    def _arrived(self, raw: bytes):
        self.times.append((time.perf_counter(), len(raw)))
        self.wall_ns.append(time.time_ns())


def round_trips(peer, publish, raw: Raw, count: int, warmup: int, timeout: float = 10.0) -> list[float]:
    """`count` round trips, one at a time, after `warmup` ones: publish, then wait for the next arrival."""
    out = []
    for k in range(count + warmup):
        before = len(raw.times)
        t0 = time.perf_counter()
        publish()
        deadline = t0 + timeout
        while len(raw.times) == before:
            peer.executor.spin_once(timeout_sec=0.005)
            if time.perf_counter() > deadline:
                raise RuntimeError(f"no answer within {timeout} s (round trip {k})")
        if k >= warmup:
            out.append(raw.times[before][0] - t0)
    return out


def service_trips(peer, client, request, count: int, warmup: int, timeout: float = 10.0) -> list[float]:
    out = []
    if not client.wait_for_service(timeout_sec=15):
        raise RuntimeError(f"service {client.srv_name} not available")
    for k in range(count + warmup):
        t0 = time.perf_counter()
        fut = client.call_async(request)
        deadline = t0 + timeout
        while not fut.done():
            peer.executor.spin_once(timeout_sec=0.005)
            if time.perf_counter() > deadline:
                raise RuntimeError(f"no reply within {timeout} s (call {k})")
        took = time.perf_counter() - t0
        if len(fut.result().recommendation_set.recommendations) != len(request.candidate_set.candidates):
            raise RuntimeError("the reply does not answer every candidate")
        if k >= warmup:
            out.append(took)
    return out


# Binaries other than the one under test, by variant name (--also-bin LABEL=PATH).
BINARIES: dict[str, Path] = {}


def start_variant(ns: str, extra: list[str], params: list[str], workdir: Path, label: str, name: str):
    """Variant `name`'s node in namespace `ns`, recording and markers off, so that only the answering is
    measured."""
    return C.NodeProcess([*extra, "--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false",
                          "-p", "publish_markers:=false", *params], C.ros_env(C.DOMAIN_ID), workdir, label,
                         binary=BINARIES.get(name))


# The node's line at debug for each set answered on the topic (src/node/sets.rs, AnswerLine).
SET_LINE = re.compile(r'\(topic\): (\d+) candidates.*taken ([0-9.]+) ms after it arrived, answered in ([0-9.]+) ms, '
                      r'published in ([0-9.]+) ms; it waited ([0-9.]+) ms for the set thread'
                      r'(?:; handed to DDS at (\d+) ns)?')


def node_times(node, n: int, arrived_ns: list[int], skip: int) -> dict | None:
    """Medians over the sets of `n` candidates a node answered (its debug lines): from the set's arrival in
    its DDS reader to the start of its answer (the thread waking, the set decoded), the answer, the
    publishing; and from the answer handed to DDS to its arrival here (`arrived_ns`, this process's system
    clock, one per set the node answered, in order): the transport and rclpy, none if the counts differ.
    The first `skip` sets (the warm-up) are left out."""
    def lines():
        # Older builds do not say when they handed the answer to DDS (None).
        return [(*map(float, m.groups()[1:5]), m.group(6) and int(m.group(6))) for line in node.all_lines()
                for m in [SET_LINE.search(line)] if m and int(m.group(1)) == n]

    # The node's last line may still be on its way through the pipe that collects them.
    deadline = time.monotonic() + 1.0
    while len(rows := lines()) < len(arrived_ns) and time.monotonic() < deadline:
        time.sleep(0.01)
    if len(rows) <= skip:
        return None
    out = {key: statistics.median(r[i] for r in rows[skip:]) for i, key in
           enumerate(("taken_ms", "answered_ms", "published_ms", "waited_ms"))}
    out["to_client_ms"] = (statistics.median((a - r[4]) / 1e6 for a, r in list(zip(arrived_ns, rows))[skip:])
                           if len(rows) == len(arrived_ns) and all(r[4] for r in rows) else None)
    return out


def measure(peer, args, name: str, extra: list[str], params: list[str], rep: int, workdir: Path) -> dict:
    from rclpy.serialization import serialize_message
    from grasp_orient.msg import GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet
    from grasp_orient.srv import Recommend

    ns = f"/bench_sets_{name}_{rep}"
    node = start_variant(ns, extra, params, workdir, f"{name} #{rep}", name)
    try:
        node.wait_ready()
        res: dict = {}
        set_pub = peer.node.create_publisher(GraspCandidateSet, f"{ns}/grasp_candidate_sets", C.reliable_qos(100))
        set_raw = Raw(peer, GripRecommendationSet, f"{ns}/grip_recommendation_sets")
        one_pub = peer.node.create_publisher(GraspCandidate, f"{ns}/grasp_candidates", C.reliable_qos(100))
        one_raw = Raw(peer, GripRecommendation, f"{ns}/grip_recommendations")
        client = peer.node.create_client(Recommend, f"{ns}/grasp_orient/recommend")
        ok = peer.spin_until(lambda: set_pub.get_subscription_count() > 0 and one_pub.get_subscription_count() > 0
                             and set_raw.sub.get_publisher_count() > 0 and one_raw.sub.get_publisher_count() > 0, 15)
        if not ok:
            raise RuntimeError(f"{name}: the topics did not match")
        big = serialize_message(set_message(candidates(args.n, 5 + rep, "big"), "big"))
        res["set_bytes"] = len(big)
        res["set"] = summary(round_trips(peer, lambda: set_pub.publish(big), set_raw, args.sets, 5, timeout=30))
        res["answer_bytes"] = set_raw.times[-1][1]
        one = candidates(1, 9, "one")
        one_msg = serialize_message(C.candidate_msg(one[0]))
        res["topic_one"] = summary(round_trips(peer, lambda: one_pub.publish(one_msg), one_raw, args.singles, 20))
        one_set = serialize_message(set_message(one, "one"))
        res["topic_set_of_one"] = summary(round_trips(peer, lambda: set_pub.publish(one_set), set_raw,
                                                      args.singles, 20))
        req = Recommend.Request()
        req.candidate_set = set_message(one, "svc")
        res["service_one"] = summary(service_trips(peer, client, req, args.singles, 20))
        for x in (set_pub, one_pub):
            peer.node.destroy_publisher(x)
        for x in (set_raw.sub, one_raw.sub):
            peer.node.destroy_subscription(x)
        peer.node.destroy_client(client)
        return res
    finally:
        node.stop()


def measure_interleaved(peer, args, variants, workdir: Path) -> dict:
    """(c) Every variant's node running at once, and one set sent to each in turn, the order turned round
    by round: the echo and the node are then measured over the same minutes, so that a machine whose
    speed drifts from one minute to the next (a shared VM) moves both alike. Returns each variant's round
    trips and, per round, the node's and node_1's over the echo's."""
    from rclpy.serialization import serialize_message
    from grasp_orient.msg import GraspCandidateSet, GripRecommendationSet

    nodes, pubs, raws = {}, {}, {}
    spaces = {name: f"/bench_sets_{name}_turns" for name, _, _ in variants}
    try:
        for name, extra, params in variants:
            # Debug lines: where each set's time in the node goes (node_times). One node at a time:
            # three participants started in the same instant did not always discover the peer.
            debug = ["--log-level", "grasp_orient.node.sets:=debug"]
            nodes[name] = start_variant(spaces[name], extra, [*params, *debug], workdir, f"{name} (turns)",
                                        name)
            nodes[name].wait_ready()
        for name, ns in spaces.items():
            pubs[name] = peer.node.create_publisher(GraspCandidateSet, f"{ns}/grasp_candidate_sets",
                                                    C.reliable_qos(100))
            raws[name] = Raw(peer, GripRecommendationSet, f"{ns}/grip_recommendation_sets")
        ok = peer.spin_until(lambda: all(pubs[n].get_subscription_count() > 0 and raws[n].sub.get_publisher_count() > 0
                                         for n in pubs), 15)
        if not ok:
            raise RuntimeError("interleaved: the topics did not match")
        big = serialize_message(set_message(candidates(args.n, 77, "turns"), "turns"))
        names = [name for name, _, _ in variants]
        lat: dict[str, list[float]] = {name: [] for name in names}
        arrived_ns: dict[str, list[int]] = {name: [] for name in names}
        rounds, warmup = args.sets * args.repeat, 5
        for k in range(rounds + warmup):
            order = names[k % len(names):] + names[:k % len(names)]
            for name in order:
                before = len(raws[name].wall_ns)
                (t,) = round_trips(peer, lambda: pubs[name].publish(big), raws[name], 1, 0, timeout=30)
                arrived_ns[name].append(raws[name].wall_ns[before])
                if k >= warmup:
                    lat[name].append(t)
        for name in names:
            peer.node.destroy_publisher(pubs[name])
            peer.node.destroy_subscription(raws[name].sub)
        out = {name: summary(lat[name]) for name in names}
        for name in names[1:]:
            out[f"{name}_over_echo_per_round"] = statistics.median(
                a / b for a, b in zip(lat[name], lat[names[0]]))
            out[f"{name}_minus_echo_per_round_ms"] = 1e3 * statistics.median(
                a - b for a, b in zip(lat[name], lat[names[0]]))
        for name in names:
            out[f"{name}_in_node"] = node_times(nodes[name], args.n, arrived_ns[name], warmup)
        return out
    finally:
        for node in nodes.values():
            node.stop()


def med(runs: list[dict], key: str, field: str) -> float:
    return statistics.median(r[key][field] for r in runs)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", help="grasp_orient binary (default: GRASP_ORIENT_BIN or target/debug)")
    ap.add_argument("--n", type=int, default=1000, help="candidates per set (default 1000)")
    ap.add_argument("--sets", type=int, default=60, help="set round trips per run (default 60)")
    ap.add_argument("--singles", type=int, default=300, help="one-candidate round trips per run (default 300)")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions, echo, node and node_1 interleaved (default 3)")
    ap.add_argument("--json", help="write every measurement here")
    ap.add_argument("--also-bin", action="append", default=[], metavar="LABEL=PATH",
                    help="another grasp_orient binary (an older build, say), run as shipped like the node and "
                         "measured in the same run; repeatable")
    ap.add_argument("--large-buffers", action="store_true",
                    help="rclpy side with 4 MB socket buffers (tests/ros/fastdds_large_buffers.xml)")
    args = ap.parse_args()
    if args.bin:
        os.environ["GRASP_ORIENT_BIN"] = str(Path(args.bin).resolve())
    import rclpy

    rclpy.init()
    peer = C.Peer("bench_sets_peer")
    workdir = Path(tempfile.mkdtemp(prefix="grasp_orient_bench_sets_"))
    # (name, arguments before --ros-args, parameters): the floor, the node as shipped (solver_threads 0:
    # one per core), and the node solving on its own thread alone, which shows what the threads buy.
    variants = [("echo", ["--echo"], []), ("node", [], []), ("node_1", [], ["-p", "solver_threads:=1"])]
    for spec in args.also_bin:
        label, _, path = spec.partition("=")
        # The label names the node's namespace: a ROS name token.
        if (not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", label) or not path
                or label in ("echo", "node", "node_1") or label in BINARIES):
            ap.error(f"--also-bin {spec!r}: want LABEL=PATH with a new label of letters, digits and _")
        BINARIES[label] = Path(path).resolve()
        variants.append((label, [], []))
    runs: dict[str, list[dict]] = {name: [] for name, _, _ in variants}
    log(f"[bench_sets] ROS_DOMAIN_ID={C.DOMAIN_ID}, binary {C.binary_path()}, sets of {args.n}, "
        f"{args.repeat} repetitions, {'4 MB' if args.large_buffers else 'default'} socket buffers on the rclpy side")
    try:
        for rep in range(args.repeat):
            for name, extra, params in variants:
                r = measure(peer, args, name, extra, params, rep, workdir)
                runs[name].append(r)
                log(f"[bench_sets] #{rep} {name}: set p50 {r['set']['p50_ms']:.2f} ms p99 {r['set']['p99_ms']:.2f} ms; "
                    f"one: topic {r['topic_one']['p50_ms']:.3f}, set of 1 {r['topic_set_of_one']['p50_ms']:.3f}, "
                    f"service {r['service_one']['p50_ms']:.3f} ms (p50)")
        turns = measure_interleaved(peer, args, variants, workdir)
    finally:
        peer.destroy()
        rclpy.try_shutdown()
    e, n, n1 = runs["echo"], runs["node"], runs["node_1"]
    cores = len(os.sched_getaffinity(0))  # what the node counts as its cores, affinity included
    print(f"medians of {args.repeat} runs; set of {args.n} candidates: {e[0]['set_bytes'] // 1000} kB in, "
          f"answer {n[0]['answer_bytes'] // 1000} kB (echo's {e[0]['answer_bytes'] // 1000} kB); "
          f"node: solver_threads 0 ({cores} cores), node_1: solver_threads 1")
    print(f"{'':34} {'echo':>8} {'node':>8} {'ratio':>7} {'node_1':>8} {'ratio':>7}")
    for label, field in (("set round trip min (ms)", "min_ms"), ("set round trip p50 (ms)", "p50_ms"),
                         ("set round trip p99 (ms)", "p99_ms")):
        a, b, c = med(e, "set", field), med(n, "set", field), med(n1, "set", field)
        print(f"{label:34} {a:8.2f} {b:8.2f} {b / a:7.2f} {c:8.2f} {c / a:7.2f}")
    print("per run, p50 echo / node / node_1 (ms): " + ", ".join(
        f"{x['set']['p50_ms']:.2f} / {y['set']['p50_ms']:.2f} / {z['set']['p50_ms']:.2f}" for x, y, z in zip(e, n, n1)))
    print(f"target: node p50 <= 1.5 x echo p50: "
          f"{'met' if med(n, 'set', 'p50_ms') <= 1.5 * med(e, 'set', 'p50_ms') else 'NOT met'}")
    te, tn, tn1 = turns["echo"], turns["node"], turns["node_1"]
    print(f"in turns, every node running at once and one set to each in turn, {te['n']} rounds:")
    print(f"  set round trip p50 (ms)          {te['p50_ms']:8.2f} {tn['p50_ms']:8.2f} {tn['p50_ms'] / te['p50_ms']:7.2f} "
          f"{tn1['p50_ms']:8.2f} {tn1['p50_ms'] / te['p50_ms']:7.2f}")
    print(f"  set round trip p99 (ms)          {te['p99_ms']:8.2f} {tn['p99_ms']:8.2f} {tn['p99_ms'] / te['p99_ms']:7.2f} "
          f"{tn1['p99_ms']:8.2f} {tn1['p99_ms'] / te['p99_ms']:7.2f}")
    print(f"  median over rounds of node / echo: {turns['node_over_echo_per_round']:.2f}, "
          f"node_1 / echo: {turns['node_1_over_echo_per_round']:.2f}")
    print(f"  median over rounds of node - echo: {turns['node_minus_echo_per_round_ms']:.2f} ms (half the echo's "
          f"p50, what the target leaves the node: {0.5 * te['p50_ms']:.2f}), node_1 - echo: "
          f"{turns['node_1_minus_echo_per_round_ms']:.2f} ms")
    print(f"target in turns: node p50 <= 1.5 x echo p50: "
          f"{'met' if tn['p50_ms'] <= 1.5 * te['p50_ms'] else 'NOT met'}")
    for label in BINARIES:
        o = runs[label]
        print(f"{label} ({BINARIES[label]}): set p50 {med(o, 'set', 'p50_ms'):.2f} ms "
              f"({med(o, 'set', 'p50_ms') / med(e, 'set', 'p50_ms'):.2f} x echo), p99 {med(o, 'set', 'p99_ms'):.2f} ms; "
              f"in turns p50 {turns[label]['p50_ms']:.2f} ms ({turns[label]['p50_ms'] / te['p50_ms']:.2f} x echo), "
              f"median over rounds {label} / echo {turns[f'{label}_over_echo_per_round']:.2f}, "
              f"{label} - echo {turns[f'{label}_minus_echo_per_round_ms']:.2f} ms")
    print("  in the node, medians over the sets (its debug lines): set arrived -> answer started (thread woken, set "
          "decoded) / answered / published; then from the answer handed to DDS to its arrival in rclpy (ms):")
    for name, _, _ in variants:
        t = turns[f"{name}_in_node"]
        to_client = "?" if t is None or t["to_client_ms"] is None else f"{t['to_client_ms']:.3f}"
        print(f"    {name:8} " + ("no debug lines" if t is None else
                                  f"{t['taken_ms']:.3f} / {t['answered_ms']:.3f} / {t['published_ms']:.3f} "
                                  f"(waited for the set thread {t['waited_ms']:.3f}); "
                                  f"{to_client}"))
    print("one candidate, node (p50 / p99 ms):")
    t = (med(n, "topic_one", "p50_ms"), med(n, "topic_one", "p99_ms"))
    for label, key in (("topic grasp_candidates -> grip_recommendations", "topic_one"),
                       ("topic, a set of 1", "topic_set_of_one"), ("service ~/recommend, a set of 1", "service_one")):
        p50, p99 = med(n, key, "p50_ms"), med(n, key, "p99_ms")
        print(f"  {label:46} {p50:7.3f} / {p99:7.3f}   ratio to the topic {p50 / t[0]:.2f} / {p99 / t[1]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps({"runs": runs, "turns": turns}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
