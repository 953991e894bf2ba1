"""Drives tests/peer/rcl_peer.c (built by tests/peer/setup.sh, path in GRASP_ORIENT_RCL_PEER): a publisher
process sending candidates at a fixed rate and a collector process counting the answers, both on rcl and
rmw_fastrtps_cpp, the stack under rclpy and rclcpp, without Python's cost per message.

    run = offered_load(in_topic, out_topic, rate=10000, count=50000, tag="t", depth=50100)
    run.collector["received"], run.collector["lag_p99_ms"], run.publisher["acked"]
"""
from __future__ import annotations

import json
import os
import struct
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import conftest as C

DIGITS = 8


def binary() -> Path:
    """The rcl peer; raises with the way to get it (never a silent skip)."""
    given = os.environ.get("GRASP_ORIENT_RCL_PEER")
    if not given:
        raise RuntimeError("GRASP_ORIENT_RCL_PEER is not set: source the env.sh that tests/peer/setup.sh prints")
    path = Path(given)
    if not path.is_file() or not os.access(path, os.X_OK):
        raise RuntimeError(f"no rcl peer at {path}: run tests/peer/setup.sh")
    return path


def write_pool(path: Path, candidates: list, tag: str):
    """Serialized GraspCandidate messages with id TAG-00000000, as the peer reads them."""
    from rclpy.serialization import serialize_message

    with open(path, "wb") as f:
        for m in candidates:
            m.id = f"{tag}-{0:0{DIGITS}d}"
            b = serialize_message(m)
            f.write(struct.pack("<I", len(b)))
            f.write(b)


@dataclass
class Run:
    rate: float
    count: int
    publisher: dict
    collector: dict

    @property
    def lost(self) -> int:
        return self.count - self.collector["received"]

    @property
    def delivered_per_s(self) -> float:
        """Distinct answers per second, from the first scheduled send to the last answer."""
        last = self.collector["last_s"]
        return self.collector["received"] / last if last and last > 0 else 0.0


def _expect_ready(p: subprocess.Popen, what: str):
    line = p.stdout.readline().strip()
    if line != "ready":
        p.kill()
        err = p.stderr.read() if p.stderr else ""
        raise RuntimeError(f"rcl peer {what} did not get ready ({line!r}): {err[-2000:]}")


def offered_load(in_topic: str, out_topic: str, out_type: str, rate: float, count: int, tag: str, depth: int,
                 idle: float = 5.0, pool: list | None = None) -> Run:
    """Publishes `count` candidates on in_topic at `rate` per second (0: as fast as possible) from one
    process, and collects distinct ids TAG-k on out_topic (type 'candidate' or 'recommendation') in another,
    until all have come or nothing new has for `idle` seconds."""
    exe = str(binary())
    env = C.ros_env(C.DOMAIN_ID)
    with tempfile.TemporaryDirectory(prefix="grasp_orient_rcl_") as tmp:
        pool_path = Path(tmp) / "pool.bin"
        if pool is None:
            import random

            rng = random.Random(11)
            pool = [C.candidate_msg(C.random_grasp(rng, f"pool-{k}")) for k in range(200)]
        write_pool(pool_path, pool, tag)
        collector = subprocess.Popen([exe, "sub", out_topic, out_type, str(count), tag, str(idle), str(depth)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=env)
        publisher = subprocess.Popen([exe, "pub", in_topic, str(pool_path), str(rate), str(count), tag, str(depth)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=env)
        try:
            _expect_ready(collector, f"collector on {out_topic}")
            _expect_ready(publisher, f"publisher on {in_topic}")
            time.sleep(0.5)  # both directions matched on the node's side too
            start = time.monotonic() + 0.2
            collector.stdin.write(f"go {start} {rate}\n")
            collector.stdin.flush()
            publisher.stdin.write(f"go {start}\n")
            publisher.stdin.flush()
            pub_stats = json.loads(publisher.stdout.readline() or "{}")
            col_stats = json.loads(collector.stdout.readline() or "{}")
            publisher.stdin.write("\n")
            publisher.stdin.flush()
        finally:
            for p in (publisher, collector):
                try:
                    p.stdin.close()
                except BrokenPipeError:
                    pass
                try:
                    p.wait(15)
                except subprocess.TimeoutExpired:
                    p.kill()
        for p, what in ((publisher, "publisher"), (collector, "collector")):
            if p.returncode != 0:
                raise RuntimeError(f"rcl peer {what} exited {p.returncode}: {p.stderr.read()[-2000:]}")
        if not pub_stats or not col_stats:
            raise RuntimeError(f"rcl peer printed no result (publisher {pub_stats}, collector {col_stats})")
        return Run(rate, count, pub_stats, col_stats)
