#!/usr/bin/env python3
"""Benchmark of the grasp_orient node over ROS 2 on loopback, against a floor (not a pytest test).

    source "$(bash tests/peer/setup.sh | tail -n1)"
    cargo build --release     # or debug; pick the binary with --bin / GRASP_ORIENT_BIN
    python benches/bench_node.py --bin target/release/grasp_orient [--rates 1000,10000,20000] [--json out.json]

In one run, for each of
    echo   `grasp_orient node --echo`: answers every candidate with an empty GripRecommendation (same header and
           id) without solving: what the ROS plumbing alone costs, the floor;
    node   `grasp_orient node` with its defaults (working directory: a temporary folder, for any recording);
    node_nomarkers  the same with -p publish_markers:=false (with --with-nomarkers),
    node_norecord   the same with -p record:=false (with --with-norecord): what recording costs,
    LABEL  another grasp_orient binary with the defaults (with --also-bin LABEL=PATH, repeatable): the
           code before a change, measured against it in the same run,
it measures
    (a) round-trip latency, rclpy publish -> rclpy receipt of the answer (raw: its serialized bytes, as in (b)),
        one candidate at a time: p50, p99, max;
    (b) sustained throughput, none lost:
        windowed  at most --window candidates unanswered at any time (below the default qos_depth 100, so no
                  keep-last history can drop one), from one publisher: answers per second;
        burst     --n-throughput candidates published as fast as possible by --publishers processes, the node run
                  with -p qos_depth:=<n> so no history is short; answers per second over the whole run, and how many
                  were lost (not answered within --idle s of the last one).
    (c) sustained offered rate, from the rcl peer (tests/peer/rcl_peer.c: C on rcl + rmw_fastrtps_cpp, the stack
        under rclpy and rclcpp, about a quarter of Python's CPU per message): one process publishes at each of
        --rates for --seconds, another collects the answers; answers per second, how many were lost, and the lag
        of each answer behind its scheduled send time (p50, p99, max). The node runs with -p qos_depth:=<n>.
Plus the peer's own ceiling: the same burst from the same publisher processes to an rclpy subscriber in this
process, no node in between (rclpy -> rclpy, GraspCandidate). When the node's and echo's throughput sit near
that ceiling, Python/rclpy is the bottleneck, not the node. On two cores, an rclpy publisher and collector
saturate the machine near 8,000 messages per second; (c) is the measurement the throughput target is read from.

--offered-only skips the ceiling, (a) and (b); --burst-only keeps only the ceiling and (b)'s burst. Each burst also
reports the CPU seconds of the node, of the collector (this process) and of the publishers until the last answer,
the datagrams the kernel dropped meanwhile at a full UDP receive buffer (/proc/net/snmp, Udp RcvbufErrors:
machine-wide, but in a burst nearly all at the collector's socket), and the time the collector waited with nothing
received for over 5 ms between the first and last answer (stalled: waiting on repair). The rclpy -> rclpy ceiling
travels over Fast DDS's shared memory on one host, not UDP, so it has no socket to overflow.

All traffic stays on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, one ROS_DOMAIN_ID for the run).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
# The pytest suite's helpers live in tests/ros: conftest (node, domain, messages) and rcl_peer.
ROS_TESTS = HERE.parent / "tests" / "ros"
sys.path.insert(0, str(ROS_TESTS))

# conftest sets ROS_DOMAIN_ID (GRASP_ORIENT_TEST_DOMAIN_ID or 1 + pid % 100) and localhost discovery before rclpy.
import conftest as C  # noqa: E402
import rcl_peer  # noqa: E402


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def percentile(xs, q):
    xs = sorted(xs)
    if not xs:
        return float("nan")
    k = (len(xs) - 1) * q
    f = int(k)
    c = min(f + 1, len(xs) - 1)
    return xs[f] + (xs[c] - xs[f]) * (k - f)


def candidate_pool(n: int, seed: int = 7):
    rng = random.Random(seed)
    return [C.candidate_msg(C.random_grasp(rng, f"pool-{k}")) for k in range(n)]


# ---------------------------------------------------------------------------------------------------
# Worker: one publisher process of a burst
# ---------------------------------------------------------------------------------------------------
def worker(topic: str, count: int, tag: str) -> int:
    import rclpy
    from grasp_orient.msg import GraspCandidate

    rclpy.init()
    node = rclpy.create_node("bench_pub_" + "".join(ch if ch.isalnum() else "_" for ch in tag))
    pub = node.create_publisher(GraspCandidate, topic, C.reliable_qos(max(count, 1)))
    pool = candidate_pool(200, seed=hash(tag) & 0xFFFF)
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("ready", flush=True)
    if sys.stdin.readline().strip() != "go":
        return 1
    t0 = time.perf_counter()
    c0 = time.process_time()
    for k in range(count):
        m = pool[k % len(pool)]
        m.id = f"{tag}-{k}"
        pub.publish(m)
    t1 = time.perf_counter()
    acked = pub.wait_for_all_acked(rclpy.duration.Duration(seconds=60))
    t2 = time.perf_counter()
    print(json.dumps({"publish_s": t1 - t0, "acked_s": t2 - t0, "acked": bool(acked),
                      "cpu_s": time.process_time() - c0}), flush=True)
    # keep the writer alive until the parent is done with the answers (it closes stdin)
    sys.stdin.readline()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def start_workers(topic: str, n: int, k: int, prefix: str):
    shares = [n // k + (1 if i < n % k else 0) for i in range(k)]
    procs = []
    for i, share in enumerate(shares):
        p = subprocess.Popen([sys.executable, __file__, "--worker", topic, str(share), f"{prefix}{i}"],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=C.ros_env(C.DOMAIN_ID))
        procs.append(p)
    for p in procs:
        line = p.stdout.readline().strip()
        if line != "ready":
            raise RuntimeError(f"publisher worker did not get ready: {line!r}")
    return procs, shares


def finish_workers(procs):
    stats = []
    for p in procs:
        line = p.stdout.readline()
        try:
            stats.append(json.loads(line))
        except json.JSONDecodeError:
            stats.append({"error": line})
    for p in procs:
        try:
            p.stdin.write("\n")
            p.stdin.close()
        except BrokenPipeError:
            pass
        p.wait(30)
    return stats


# ---------------------------------------------------------------------------------------------------
# Measurements
# ---------------------------------------------------------------------------------------------------
def use_raw_answers(peer, client, ns: str):
    """Replace the client's answer subscription by a raw one (ids read from the CDR bytes, see cdr_id), so that
    rclpy's deserialization of the node's full answers, which the echo's empty answers do not pay, is not counted
    against the node. Hooks then receive the id as bytes."""
    from grasp_orient.msg import GripRecommendation

    peer.node.destroy_subscription(client.sub)
    client.sub = peer.node.create_subscription(
        GripRecommendation, f"{ns}/grip_recommendations",
        lambda raw: client.hook(cdr_id(raw)) if client.hook is not None else None, C.reliable_qos(1000), raw=True)
    if not peer.spin_until(lambda: client.sub.get_publisher_count() > 0, 15):
        raise RuntimeError(f"the raw subscription on {ns}/grip_recommendations did not match")
    peer.spin_for(0.3)


def measure_latency(peer, client, n: int, pool) -> dict:
    got = {}
    client.hook = lambda cid: got.__setitem__(cid.decode(), time.perf_counter())
    lat = []
    ex = peer.executor
    try:
        for k in range(n + 50):  # the first 50 are a warm-up
            m = pool[k % len(pool)]
            cid = f"lat-{k}"
            m.id = cid
            t0 = time.perf_counter()
            client.pub.publish(m)
            deadline = t0 + 5.0
            while cid not in got:
                ex.spin_once(timeout_sec=0.01)
                if time.perf_counter() > deadline:
                    raise RuntimeError(f"no answer to {cid} within 5 s (latency run)")
            if k >= 50:
                lat.append(got[cid] - t0)
    finally:
        client.hook = None
    return {"n": len(lat), "p50_ms": 1e3 * percentile(lat, 0.5), "p99_ms": 1e3 * percentile(lat, 0.99),
            "max_ms": 1e3 * max(lat), "mean_ms": 1e3 * statistics.fmean(lat)}


def measure_windowed(peer, client, n: int, window: int, pool) -> dict:
    got = set()
    client.hook = got.add
    ex = peer.executor
    sent = 0
    t0 = time.perf_counter()
    deadline = t0 + 300
    try:
        while len(got) < n and time.perf_counter() < deadline:
            while sent < n and sent - len(got) < window:
                m = pool[sent % len(pool)]
                m.id = f"win-{sent}"
                client.pub.publish(m)
                sent += 1
            ex.spin_once(timeout_sec=0.01)
        t1 = time.perf_counter()
    finally:
        client.hook = None
    return {"n": n, "answered": len(got), "lost": n - len(got), "per_s": len(got) / (t1 - t0),
            "seconds": t1 - t0}


def cdr_id(buf: bytes) -> bytes:
    """The string after the header in a serialized GraspCandidate or GripRecommendation (id / candidate_id),
    read from the CDR bytes without deserializing the message (rclpy's deserialization is what limits a
    Python subscriber)."""
    little = buf[1] == 1  # encapsulation CDR_LE / CDR_BE
    order = "little" if little else "big"
    o = 4 + 8  # encapsulation header, stamp (sec, nanosec)
    n = int.from_bytes(buf[o:o + 4], order)
    o += 4 + n
    o = 4 + ((o - 4 + 3) & ~3)  # align 4 relative to the start of the data
    n = int.from_bytes(buf[o:o + 4], order)
    return buf[o + 4:o + 4 + n - 1]


# A gap between two answers longer than this counts as a stall (the collector waiting, not working).
STALL_S = 0.005


def udp_rcvbuf_errors() -> int:
    """Datagrams the kernel dropped because a UDP socket's receive buffer was full (/proc/net/snmp, Udp
    RcvbufErrors): for the whole network namespace, so every socket on this machine counts, though in a burst
    nearly all are the collector's (the socket that receives the node's answers)."""
    try:
        lines = [line.split() for line in Path("/proc/net/snmp").read_text().splitlines() if line.startswith("Udp:")]
        return int(lines[1][lines[0].index("RcvbufErrors")])
    except (OSError, ValueError, IndexError):
        return -1


def process_cpu_s(pid: int | None) -> float:
    """User plus system CPU seconds of process `pid` so far, all its threads (/proc/<pid>/stat)."""
    if pid is None:
        return float("nan")
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def measure_burst(peer, in_topic: str, out_topic: str, out_type, n: int, k: int, idle: float, prefix: str,
                  node_pid: int | None = None) -> dict:
    """k publisher processes send n candidates on in_topic as fast as they can; count distinct ids on out_topic
    (received raw: serialized bytes, id read from the CDR, so that this subscriber is as cheap as rclpy allows).
    Also the CPU seconds of the node (node_pid), of this collector process and of the publishers from the start
    to the last answer (the idle wait after it excluded), and the UDP receive-buffer drops meanwhile."""
    got = set()
    t_last = [0.0]
    # time with nothing received for more than STALL_S (waiting on repair, once the first answer came)
    stalls = [0.0, 0]

    def on(raw: bytes):
        got.add(cdr_id(raw))
        now = time.perf_counter()
        if got and t_last[0] > 0 and now - t_last[0] > STALL_S:
            stalls[0] += now - t_last[0]
            stalls[1] += 1
        t_last[0] = now

    sub = peer.node.create_subscription(out_type, out_topic, on, C.reliable_qos(n + 100), raw=True)
    procs, shares = start_workers(in_topic, n, k, prefix)
    try:
        # the answer path must be matched too before the clock starts
        if not peer.spin_until(lambda: sub.get_publisher_count() > 0, 15):
            raise RuntimeError(f"nothing publishes on {out_topic}")
        peer.spin_for(0.5)
        drops0, node_cpu0, cpu0 = udp_rcvbuf_errors(), process_cpu_s(node_pid), time.process_time()
        node_cpu_last, cpu_last, drops_last = node_cpu0, cpu0, drops0
        t0 = time.perf_counter()
        for p in procs:
            p.stdin.write("go\n")
            p.stdin.flush()
        ex = peer.executor
        last_count, last_change = 0, time.perf_counter()
        while len(got) < n:
            ex.spin_once(timeout_sec=0.05)
            if len(got) != last_count:
                last_count, last_change = len(got), time.perf_counter()
                node_cpu_last, cpu_last, drops_last = process_cpu_s(node_pid), time.process_time(), udp_rcvbuf_errors()
            elif time.perf_counter() - last_change > idle:
                break
        stats = finish_workers(procs)
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
        peer.node.destroy_subscription(sub)
    span = (t_last[0] - t0) if got else float("nan")
    pub_rate = sum(shares) / max(s.get("publish_s", float("nan")) for s in stats) if stats else float("nan")
    return {"n": n, "publishers": k, "answered": len(got), "lost": n - len(got),
            "per_s": len(got) / span if got else 0.0, "seconds": span,
            "publish_only_per_s": pub_rate, "workers": stats,
            "node_cpu_s": node_cpu_last - node_cpu0, "collector_cpu_s": cpu_last - cpu0,
            "publisher_cpu_s": sum(s.get("cpu_s", float("nan")) for s in stats),
            "rcvbuf_drops": drops_last - drops0 if drops0 >= 0 else -1,
            "stall_s": stalls[0], "stalls": stalls[1]}


def offered_count(rate: int, seconds: float) -> int:
    return max(1, int(round(rate * seconds)))


def offered_depth(rate: int, seconds: float) -> int:
    """Keep-last depth for (c): room for the whole run, within the node's limit on qos_depth (100000)."""
    return min(offered_count(rate, seconds) + 100, 100_000)


def offered_summary(r: "rcl_peer.Run") -> dict:
    return {"rate": r.rate, "n": r.count, "answered": r.collector["received"], "lost": r.lost,
            "duplicates": r.collector["duplicates"], "per_s": r.delivered_per_s,
            "lag_p50_ms": r.collector["lag_p50_ms"], "lag_p99_ms": r.collector["lag_p99_ms"],
            "lag_max_ms": r.collector["lag_max_ms"], "publisher": r.publisher, "collector_cpu_s": r.collector["cpu_s"]}


# ---------------------------------------------------------------------------------------------------
def median_of(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs) if runs else float("nan")


def spread(runs: list[dict], key: str, fmt: str) -> str:
    if len(runs) < 2:
        return ""
    xs = [r[key] for r in runs]
    return f" [{format(min(xs), fmt)}..{format(max(xs), fmt)}]"


def run(args) -> int:
    import rclpy
    from grasp_orient.msg import GraspCandidate, GripRecommendation

    rclpy.init()
    if args.executor == "events":
        # rclpy's C++ EventsExecutor (experimental in Jazzy): about 6x the messages per second of the
        # SingleThreadedExecutor in a Python subscriber here, so the peer is less of a bottleneck
        from rclpy.experimental.events_executor import EventsExecutor as factory
    else:
        from rclpy.executors import SingleThreadedExecutor as factory
    peer = C.Peer("bench_peer", factory)
    pool = candidate_pool(500)
    workdir = Path(tempfile.mkdtemp(prefix="grasp_orient_bench_"))
    variants = [("echo", ["--echo"]), ("node", [])]
    if args.with_nomarkers:
        variants.append(("node_nomarkers", ["--ros-args", "-p", "publish_markers:=false"]))
    if args.with_norecord:
        variants.append(("node_norecord", ["--ros-args", "-p", "record:=false"]))
    # other binaries (an older build, say), run with the defaults like `node`, interleaved with it
    binaries = {}
    for spec in args.also_bin:
        label, _, path = spec.partition("=")
        binaries[label] = Path(path).resolve()
        variants.append((label, []))
    names = ["rclpy->rclpy"] + [v[0] for v in variants]
    # every measurement, per variant and kind, one entry per repetition
    results: dict = {n: {"latency": [], "windowed": [], "burst": [], "offered": {r: [] for r in args.rates},
                         "errors": []} for n in names}

    log(f"[bench] ROS_DOMAIN_ID={C.DOMAIN_ID}, binary {C.binary_path()}, {args.repeat} repetitions, "
        f"echo and node interleaved")
    for rep in range(args.repeat):
        if not args.offered_only:
            # the peer's own ceiling, no node: publisher processes -> this process, GraspCandidate
            r = measure_burst(peer, f"/bench_loop_{rep}", f"/bench_loop_{rep}", GraspCandidate, args.n_throughput,
                              args.publishers, args.idle, f"loop{rep}-")
            results["rclpy->rclpy"]["burst"].append(r)
            log(f"[bench] #{rep} rclpy->rclpy burst {r['per_s']:.0f}/s, lost {r['lost']}, CPU s collector "
                f"{r['collector_cpu_s']:.2f} publisher {r['publisher_cpu_s']:.2f}, UDP receive-buffer drops "
                f"{r['rcvbuf_drops']}")
        for name, extra in variants:
            # (c) starts a fresh node for every rate: in one node, each publisher/collector pair that has come
            # and gone leaves the next run a higher p99 lag (docs/performance.md, "Known limit: peers that leave"), which would mix the rates up.
            phases = ([] if args.offered_only else ["burst"] if args.burst_only else ["latency+windowed", "burst"])
            for phase in [*phases, *(f"offered{rate}" for rate in args.rates)]:
                ns = f"/bench_{name}_{phase.split('+')[0]}_{rep}"
                ros_args = ["-r", f"__ns:={ns}"]
                rate = int(phase[len("offered"):]) if phase.startswith("offered") else None
                if phase == "burst":
                    ros_args += ["-p", f"qos_depth:={args.n_throughput + 100}"]
                if rate is not None:
                    ros_args += ["-p", f"qos_depth:={offered_depth(rate, args.seconds)}"]
                node_args = [*extra, *ros_args] if "--ros-args" in extra else [*extra, "--ros-args", *ros_args]
                proc = C.NodeProcess(node_args, C.ros_env(C.DOMAIN_ID), workdir, f"{name} ({phase})",
                                     binary=binaries.get(name))
                res = results[name]
                try:
                    try:
                        proc.wait_ready()
                    except BaseException as e:  # pytest.fail outside pytest
                        log(f"[bench] {name} did not start: {e}")
                        res["errors"].append(str(e).splitlines()[0])
                        continue
                    if rate is not None:
                        n = offered_count(rate, args.seconds)
                        try:
                            r = rcl_peer.offered_load(f"{ns}/grasp_candidates", f"{ns}/grip_recommendations",
                                                      "recommendation", rate, n, f"{name}{rep}r{rate}",
                                                      offered_depth(rate, args.seconds), idle=args.idle)
                        except RuntimeError as e:
                            log(f"[bench] {name} offered {rate}/s: {e}")
                            res["errors"].append(str(e).splitlines()[0])
                            continue
                        res["offered"][rate].append(offered_summary(r))
                        log(f"[bench] #{rep} {name}: offered {rate}/s -> {r.delivered_per_s:.0f}/s lost {r.lost} "
                            f"lag p50 {r.collector['lag_p50_ms']:.2f} p99 {r.collector['lag_p99_ms']:.2f} ms")
                        continue
                    client = C.GraspClient(peer, ns=ns)
                    try:
                        client.ensure_roundtrip()
                    except AssertionError as e:
                        log(f"[bench] {name}: {e}")
                        res["errors"].append(str(e))
                        continue
                    if phase == "latency+windowed":
                        use_raw_answers(peer, client, ns)
                        lat = measure_latency(peer, client, args.n_latency, pool)
                        win = measure_windowed(peer, client, args.n_windowed, args.window, pool)
                        res["latency"].append(lat)
                        res["windowed"].append(win)
                        log(f"[bench] #{rep} {name}: latency p50 {lat['p50_ms']:.3f} ms p99 {lat['p99_ms']:.3f} ms; "
                            f"windowed {win['per_s']:.0f}/s lost {win['lost']}")
                    else:
                        b = measure_burst(peer, f"{ns}/grasp_candidates", f"{ns}/grip_recommendations",
                                          GripRecommendation, args.n_throughput, args.publishers, args.idle,
                                          f"{name}{rep}-", node_pid=proc.proc.pid)
                        # answers the node could not hand to DDS (its log says so), as opposed to lost on the way
                        errors = [line for line in proc.all_lines() if "cannot publish" in line]
                        b["publish_errors"] = len(errors)
                        if errors:
                            log(f"[bench] {name}: {errors[0][:300]}")
                        res["burst"].append(b)
                        log(f"[bench] #{rep} {name}: {b['publish_errors']} publish errors; burst {b['per_s']:.0f}/s lost {b['lost']}, CPU s node "
                            f"{b['node_cpu_s']:.2f} collector {b['collector_cpu_s']:.2f} publisher "
                            f"{b['publisher_cpu_s']:.2f}, UDP receive-buffer drops {b['rcvbuf_drops']}, {b['stalls']} stalls "
                            f"over {1e3 * STALL_S:.0f} ms, {b['stall_s']:.2f} s in all")
                    peer.node.destroy_publisher(client.pub)
                    peer.node.destroy_subscription(client.sub)
                finally:
                    rc = proc.stop()
                    if rc != 0:
                        res["errors"].append(f"exit {rc} after SIGINT")
                        log(f"[bench] {name} exited {rc} after SIGINT:\n{proc.output(20)}")
    peer.destroy()
    rclpy.try_shutdown()

    # ------------------------------------------------------------------ report (medians over repetitions)
    print(f"\ngrasp_orient node benchmark, loopback, ROS_DOMAIN_ID={C.DOMAIN_ID}, binary {C.binary_path()}")
    print(f"peer: rclpy (Jazzy, rmw_fastrtps_cpp), {args.executor} executor; {os.cpu_count()} cores; "
          f"median of {args.repeat} interleaved repetitions [min..max]\n")
    print(f"(a) round trip, one at a time ({args.n_latency} each): p50 ms, p99 ms, max ms")
    for name in names[1:]:
        L = results[name]["latency"]
        if L:
            print(f"    {name:<14} p50 {median_of(L, 'p50_ms'):.3f}{spread(L, 'p50_ms', '.3f')}   "
                  f"p99 {median_of(L, 'p99_ms'):.3f}{spread(L, 'p99_ms', '.3f')}   max {max(x['max_ms'] for x in L):.2f}")
        else:
            print(f"    {name:<14} n/a: {results[name]['errors'][:1] or 'not measured'}")
    print(f"\n(b) throughput, answers per second")
    print(f"    windowed: at most {args.window} unanswered, {args.n_windowed} candidates, default qos_depth")
    print(f"    burst: {args.n_throughput} as fast as {args.publishers} publisher process(es) can, qos_depth "
          f"{args.n_throughput + 100}; 'publish' is the publishers' own rate")
    for name in names:
        W, B_ = results[name]["windowed"], results[name]["burst"]
        line = f"    {name:<14}"
        if W:
            line += f" windowed {median_of(W, 'per_s'):7.0f}{spread(W, 'per_s', '.0f')} lost {sum(w['lost'] for w in W)}"
        if B_:
            line += (f"   burst {median_of(B_, 'per_s'):7.0f}{spread(B_, 'per_s', '.0f')} "
                     f"lost {sum(b['lost'] for b in B_)}   publish {median_of(B_, 'publish_only_per_s'):.0f}")
            line += (f"   CPU s node {median_of(B_, 'node_cpu_s'):.2f} collector {median_of(B_, 'collector_cpu_s'):.2f} "
                     f"publisher {median_of(B_, 'publisher_cpu_s'):.2f}   UDP drops "
                     f"{median_of(B_, 'rcvbuf_drops'):.0f}{spread(B_, 'rcvbuf_drops', '.0f')}   stalled "
                     f"{median_of(B_, 'stall_s'):.2f} s{spread(B_, 'stall_s', '.2f')}")
        print(line)
    if args.rates:
        print(f"\n(c) sustained offered rate: one rcl publisher process -> node -> one rcl collector process "
              f"(C, rmw_fastrtps_cpp), {args.seconds:g} s at each rate, qos_depth <n>;\n"
              f"    answers per second (first scheduled send to last answer), lost, lag behind the scheduled send "
              f"p50/p99/max ms")
        for rate in args.rates:
            for name in names[1:]:
                R = results[name]["offered"][rate]
                if not R:
                    print(f"    offered {rate:>6}/s  {name:<14} n/a")
                    continue
                print(f"    offered {rate:>6}/s  {name:<14} {median_of(R, 'per_s'):7.0f}/s{spread(R, 'per_s', '.0f')} "
                      f"lost {sum(x['lost'] for x in R)}   lag p50 {median_of(R, 'lag_p50_ms'):.2f} "
                      f"p99 {median_of(R, 'lag_p99_ms'):.2f} max {max(x['lag_max_ms'] for x in R):.1f}")
        kept = [rate for rate in args.rates
                if results["node"]["offered"][rate] and len(results["node"]["offered"][rate]) == args.repeat
                and all(x["lost"] == 0 and x["per_s"] >= 0.98 * rate for x in results["node"]["offered"][rate])]
        print(f"    node kept up (none lost, at least 98 % of the offered rate, every repetition) at: "
              f"{', '.join(f'{r}/s' for r in kept) or 'none of the offered rates'}")
    e, nd = results["echo"], results["node"]
    if e["latency"] and nd["latency"]:
        print(f"\nratios node/echo (medians): latency p50 {median_of(nd['latency'], 'p50_ms') / median_of(e['latency'], 'p50_ms'):.2f}, "
              f"p99 {median_of(nd['latency'], 'p99_ms') / median_of(e['latency'], 'p99_ms'):.2f}; "
              f"windowed throughput {median_of(nd['windowed'], 'per_s') / median_of(e['windowed'], 'per_s'):.2f}"
              + (f"; burst throughput {median_of(nd['burst'], 'per_s') / median_of(e['burst'], 'per_s'):.2f}"
                 if e["burst"] and nd["burst"] else ""))
    for rate in args.rates:
        eo, no = e["offered"][rate], nd["offered"][rate]
        if eo and no:
            print(f"ratios node/echo at an offered {rate}/s (medians): answers per second "
                  f"{median_of(no, 'per_s') / median_of(eo, 'per_s'):.2f}, lag p50 "
                  f"{median_of(no, 'lag_p50_ms') / median_of(eo, 'lag_p50_ms'):.2f}, p99 "
                  f"{median_of(no, 'lag_p99_ms') / median_of(eo, 'lag_p99_ms'):.2f}")
        for name in names[3:]:
            vo = results[name]["offered"][rate]
            if eo and vo:
                print(f"ratios {name}/echo at an offered {rate}/s (medians): lag p50 "
                      f"{median_of(vo, 'lag_p50_ms') / median_of(eo, 'lag_p50_ms'):.2f}, p99 "
                      f"{median_of(vo, 'lag_p99_ms') / median_of(eo, 'lag_p99_ms'):.2f}")
    ceiling = median_of(results["rclpy->rclpy"]["burst"], "per_s")
    if nd["burst"] and results["rclpy->rclpy"]["burst"]:
        print(f"peer ceiling (rclpy -> rclpy, no node, same publishers and collector): {ceiling:.0f}/s; "
              f"node burst / ceiling {median_of(nd['burst'], 'per_s') / ceiling:.2f}")
        # each repetition's burst over the ceiling measured just before it
        for name in names[1:]:
            pairs = zip(results["rclpy->rclpy"]["burst"], results[name]["burst"])
            ratios = [f"{b['per_s'] / c['per_s']:.2f}" for c, b in pairs if c["per_s"] > 0]
            if ratios:
                print(f"    {name} burst / ceiling of its repetition: {', '.join(ratios)}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))
    failed = (any(r["errors"] for r in results.values())
              or any(w["lost"] for r in results.values() for w in r["windowed"]))
    return 1 if failed else 0


def main() -> int:
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        return worker(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    ap = argparse.ArgumentParser(description="grasp_orient node benchmark against `node --echo` (see the docstring)")
    ap.add_argument("--bin", help="grasp_orient binary (default: GRASP_ORIENT_BIN or target/debug/grasp_orient)")
    ap.add_argument("--n-latency", type=int, default=2000)
    ap.add_argument("--n-windowed", type=int, default=5000)
    ap.add_argument("--window", type=int, default=50)
    ap.add_argument("--n-throughput", type=int, default=20000)
    ap.add_argument("--publishers", type=int, default=1, help="publisher processes for the burst (1)")
    ap.add_argument("--rates", type=lambda v: [int(x) for x in v.split(",") if x.strip()], default=[1000, 10000, 20000],
                    help="offered rates per second for (c), comma-separated ('' skips (c)); default 1000,10000,20000")
    ap.add_argument("--seconds", type=float, default=5.0, help="duration of each offered rate in (c) (5 s)")
    ap.add_argument("--idle", type=float, default=5.0, help="burst ends this long after the last answer (5 s)")
    ap.add_argument("--executor", choices=["events", "single"], default="events",
                    help="rclpy executor of the measuring peer (events: rclpy.experimental EventsExecutor)")
    ap.add_argument("--with-nomarkers", action="store_true",
                    help="also the node with -p publish_markers:=false (what the markers cost)")
    ap.add_argument("--with-norecord", action="store_true",
                    help="also the node with -p record:=false (what recording to MCAP costs)")
    ap.add_argument("--also-bin", action="append", default=[], metavar="LABEL=PATH",
                    help="also this grasp_orient binary with the defaults, reported as LABEL (repeatable)")
    ap.add_argument("--offered-only", action="store_true",
                    help="only (c), the sustained offered rates: no ceiling, latency, windowed or burst")
    ap.add_argument("--burst-only", action="store_true",
                    help="only the ceiling and (b)'s burst: no latency, windowed or offered rates")
    ap.add_argument("--repeat", type=int, default=3, help="interleaved repetitions; medians are reported (3)")
    ap.add_argument("--json", help="write every number to this file as JSON")
    args = ap.parse_args()
    if args.bin:
        os.environ["GRASP_ORIENT_BIN"] = str(Path(args.bin).resolve())
    if C.RCLPY_IMPORT_ERROR:
        log(C.RCLPY_IMPORT_ERROR)
        return 1
    if args.burst_only:
        args.rates = []
    if args.rates:
        try:
            rcl_peer.binary()
        except RuntimeError as e:
            log(f"{e} (or skip the sustained-rate measurement with --rates '')")
            return 1
    b = C.binary_path()
    if not b.is_file():
        log(f"no grasp_orient binary at {b}: cargo build, or --bin")
        return 1
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
