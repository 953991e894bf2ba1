#!/usr/bin/env python3
"""The rclpy side of tests/ros/test_hosts.py, run in the second network namespace (its rclpy must start
there, with that side's discovery settings, so it cannot be the test session's own). Prints one JSON object
on stdout.

    python tests/ros/hosts_peer.py graph                 candidates, a set and the service, once each
    python tests/ros/hosts_peer.py burst --runs 20 --n 205 --interval 0.002
                                                          runs of N candidates, one every INTERVAL s,
                                                          every answer's arrival timed from its candidate
    python tests/ros/hosts_peer.py sets --sets 5 --n 1000 --snapshot 'SHELL COMMAND'
                                                          sets of N candidates, one at a time, each answered;
                                                          the command's output taken before and after them,
                                                          and again after as long with no sets

The discovery settings come from the environment this process is given (ROS_DOMAIN_ID,
ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS): conftest.py, imported for its helpers, sets its own
(localhost) ones, so they are put back before rclpy starts.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
GIVEN = {k: os.environ.get(k) for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS")}

import conftest as C  # noqa: E402  (sets the environment of the test session: undone below)

for key, value in GIVEN.items():
    if value is None:
        os.environ.pop(key, None)
    else:
        os.environ[key] = value


def graph(peer, args) -> dict:
    """A candidate, a set and the service, each answered, as test_node.py and test_sets.py check them."""
    from grasp_orient.msg import GraspCandidateSet, GripRecommendationSet
    from grasp_orient.srv import Recommend

    client = C.GraspClient(peer)
    client.wait_matched(args.timeout)
    rng = random.Random(120613)
    cands = [C.random_grasp(rng, f"hosts-{k}", "object") for k in range(args.n)]
    answers = client.send_and_collect(cands, timeout=args.timeout)

    sets: dict[str, object] = {}
    pub = peer.node.create_publisher(GraspCandidateSet, "grasp_candidate_sets", C.reliable_qos(10))
    sub = peer.node.create_subscription(GripRecommendationSet, "grip_recommendation_sets",
                                        lambda m: sets.setdefault(m.set_id, m), C.reliable_qos(10))
    s = GraspCandidateSet()
    s.id = "hosts-set"
    s.candidates = [C.candidate_msg(c) for c in cands[:5]]
    # Both directions: an answer published before the node's publisher matches this new
    # subscription would be lost (reliable, volatile).
    matched = lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0  # noqa: E731
    assert peer.spin_until(matched, args.timeout), "no match on the set topics"
    pub.publish(s)
    assert peer.spin_until(lambda: s.id in sets, args.timeout), "no answer to the set"

    srv = peer.node.create_client(Recommend, "grasp_orient/recommend")
    req = Recommend.Request()
    req.candidate_set = s
    reply = peer.call(srv, req, timeout=args.timeout).recommendation_set
    return {
        "candidates": len(answers),
        "answered_ids": sorted(a.candidate_id for a in answers.values()) == sorted(c["id"] for c in cands),
        "set": [r.candidate_id for r in sets[s.id].recommendations],
        "service": [r.candidate_id for r in reply.recommendations],
    }


def burst(peer, args) -> dict:
    """`runs` runs of `n` candidates, one published every `interval` s (spinning in between); per run, the
    seconds from the last candidate published to each answer and each candidate's round trip. A run ends when
    all are answered or `timeout` s after its last candidate."""
    client = C.GraspClient(peer)
    client.ensure_roundtrip(args.timeout)
    rng = random.Random(120614)
    runs = []
    for run in range(args.runs):
        cands = [C.random_grasp(rng, f"burst-{run}-{k}", "object") for k in range(args.n)]
        msgs = [C.candidate_msg(c) for c in cands]
        sent: dict[str, float] = {}
        got: dict[str, float] = {}
        client.hook = lambda m: got.setdefault(m.candidate_id, time.monotonic())
        due = time.monotonic()
        for c, m in zip(cands, msgs):
            peer.spin_until(lambda: time.monotonic() >= due, args.interval)
            sent[c["id"]] = time.monotonic()
            client.pub.publish(m)
            due += args.interval
        last = time.monotonic()
        peer.spin_until(lambda: all(i in got for i in sent), args.timeout)
        client.hook = None
        runs.append({
            "answered": sum(1 for i in sent if i in got),
            # in publishing order; None for a candidate not answered
            "after_last_s": [got[i] - last if i in got else None for i in sent],
            "round_trip_s": sorted(got[i] - sent[i] for i in sent if i in got),
        })
    return {"n": args.n, "runs": runs}


def snapshot(command: str) -> dict:
    """The output of `command` (run by sh) and when it was taken (monotonic s)."""
    r = subprocess.run(["sh", "-c", command], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, f"the snapshot command exited {r.returncode}: {r.stderr.strip()}"
    return {"t": time.monotonic(), "out": r.stdout}


def sets(peer, args) -> dict:
    """A warm-up set, then `sets` sets of `n` candidates, each published once the previous one is answered,
    with snapshots (`--snapshot`) before the first and `--settle` s after the last answer; then as long again
    with no sets, and a last snapshot (what crosses with nothing sent). The sizes are the CDR sizes
    (serialize_message for the set, the raw answer as it arrives), encapsulation header included."""
    from rclpy.serialization import serialize_message
    from grasp_orient.msg import GraspCandidateSet, GripRecommendationSet

    answers: list[int] = []
    pub = peer.node.create_publisher(GraspCandidateSet, "grasp_candidate_sets", C.reliable_qos(10))
    sub = peer.node.create_subscription(GripRecommendationSet, "grip_recommendation_sets",
                                        lambda raw: answers.append(len(raw)), C.reliable_qos(10), raw=True)
    assert peer.spin_until(lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0,
                           args.timeout), "no match on the set topics"
    rng = random.Random(120615)
    msgs = []
    for k in range(args.sets + 1):
        s = GraspCandidateSet()
        s.id = f"wire-{k}"
        s.candidates = [C.candidate_msg(C.random_grasp(rng, f"wire-{k}-{j}", "object")) for j in range(args.n)]
        msgs.append(serialize_message(s))

    def send(msg: bytes, what: str):
        before = len(answers)
        pub.publish(msg)
        assert peer.spin_until(lambda: len(answers) > before, args.timeout, step=0.002), f"no answer to {what}"

    send(msgs[0], "the warm-up set")
    peer.spin_for(args.settle)
    first = len(answers)
    snaps = [snapshot(args.snapshot)]
    for k, msg in enumerate(msgs[1:]):
        send(msg, f"set {k}")
    peer.spin_for(args.settle)
    snaps.append(snapshot(args.snapshot))
    peer.spin_for(snaps[1]["t"] - snaps[0]["t"])
    snaps.append(snapshot(args.snapshot))
    return {"request_bytes": [len(m) for m in msgs[1:]], "answer_bytes": answers[first:], "snapshots": snaps}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mode", choices=["graph", "burst", "sets"])
    ap.add_argument("--n", type=int, default=20, help="candidates (per run)")
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--interval", type=float, default=0.002, help="s between candidates in a burst run")
    ap.add_argument("--timeout", type=float, default=30.0, help="s to wait for discovery and for answers")
    ap.add_argument("--sets", type=int, default=5, help="sets measured (sets mode)")
    ap.add_argument("--settle", type=float, default=0.5, help="s spun before and after the sets (sets mode)")
    ap.add_argument("--snapshot", default="true", help="shell command whose output is taken (sets mode)")
    args = ap.parse_args()
    import rclpy

    rclpy.init()
    peer = C.Peer("grasp_orient_hosts_peer")
    try:
        result = {"graph": graph, "burst": burst, "sets": sets}[args.mode](peer, args)
    except AssertionError as e:
        result = {"error": str(e)}
    finally:
        peer.destroy()
        rclpy.try_shutdown()
    print(json.dumps(result))
    return 0 if "error" not in result else 1


if __name__ == "__main__":
    sys.exit(main())
