#!/usr/bin/env python3
"""A deliberately slow rclpy reader of the node's answers: 16 kB socket buffers
(tests/ros/fastdds_small_buffers.xml) and a callback that sleeps --sleep-ms per answer. Prints "ready" once
matched, then, when --count answers came or --timeout s passed, one JSON line: how many came, when the last
came (s after the first), and how many datagrams the kernel dropped at this process's UDP sockets
(/proc/net/udp's drops column; the receive buffer was full).

    python tests/ros/slow_reader.py NAMESPACE --count 2000

Run by tests/ros/test_slow_reader.py (the profile must be loaded before rclpy starts, so it is a process of
its own). By hand, give it the node's domain: GRASP_ORIENT_TEST_DOMAIN_ID=N.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
for var in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
    os.environ[var] = str(HERE / "fastdds_small_buffers.xml")
sys.path.insert(0, str(HERE))

import conftest as C  # noqa: E402  (the session's domain and localhost discovery)


def udp_drops() -> int:
    """Datagrams dropped at this process's UDP sockets (receive buffer full)."""
    inodes = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    drops = 0
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            cols = line.split()
            if len(cols) > 12 and cols[9] in inodes:
                drops += int(cols[12])
    return drops


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("namespace")
    ap.add_argument("--count", type=int, required=True, help="answers to wait for")
    ap.add_argument("--sleep-ms", type=float, default=1.0, help="sleep in the callback per answer")
    ap.add_argument("--timeout", type=float, default=120.0)
    args = ap.parse_args()
    import rclpy
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from grasp_orient.msg import GripRecommendation

    rclpy.init()
    node = rclpy.create_node("grasp_orient_slow_reader")
    times: list[float] = []

    def on_answer(_raw):
        times.append(time.monotonic())
        time.sleep(args.sleep_ms / 1000.0)

    # KEEP_ALL: a reader that is behind holds the node back instead of losing answers from its history.
    qos = QoSProfile(depth=1, history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.VOLATILE)
    ns = args.namespace.rstrip("/")
    sub = node.create_subscription(GripRecommendation, f"{ns}/grip_recommendations", on_answer, qos, raw=True)
    deadline = time.monotonic() + 30.0
    while sub.get_publisher_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("ready" if sub.get_publisher_count() else "unmatched", flush=True)
    deadline = time.monotonic() + args.timeout
    while len(times) < args.count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print(json.dumps({
        "received": len(times),
        "span_s": (times[-1] - times[0]) if times else None,
        "udp_drops": udp_drops(),
    }), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
