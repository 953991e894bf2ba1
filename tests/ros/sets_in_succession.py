#!/usr/bin/env python3
"""Sends sets of candidates to a running node one after the other, each once the previous one is answered,
from an rclpy process with 4 MB socket buffers (tests/ros/fastdds_large_buffers.xml, as a user who receives
answers of hundreds of kB sets them), and prints the round trips as JSON on stdout:

    python tests/ros/sets_in_succession.py NAMESPACE [--sets 200] [--n 1000]

Run by tests/ros/test_sets.py::test_sets_in_quick_succession_are_never_held_back (the process's rclpy must load
the profile before it starts, so it cannot be the test session's own). By hand, give it the node's domain as
conftest.py takes it: GRASP_ORIENT_TEST_DOMAIN_ID=N (else it picks a domain of its own and matches nothing).
The set is serialized once and published as bytes; the answers are taken raw (only their arrival is timed).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
for var in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
    os.environ[var] = str(HERE / "fastdds_large_buffers.xml")
REPO_ROOT = HERE.parent.parent
# benches/bench_sets.py puts tests/ros (conftest) on sys.path itself.
sys.path.insert(0, str(REPO_ROOT / "benches"))

import bench_sets as B  # noqa: E402  (its set, raw subscription and round trips; conftest's domain)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("namespace")
    ap.add_argument("--sets", type=int, default=200)
    ap.add_argument("--n", type=int, default=1000, help="candidates per set")
    ap.add_argument("--timeout", type=float, default=30.0, help="s to wait for each answer")
    args = ap.parse_args()
    import rclpy
    from rclpy.serialization import serialize_message
    from grasp_orient.msg import GraspCandidateSet, GripRecommendationSet

    C = B.C
    rclpy.init()
    peer = C.Peer("sets_in_succession")
    ns = args.namespace.rstrip("/")
    try:
        pub = peer.node.create_publisher(GraspCandidateSet, f"{ns}/grasp_candidate_sets", C.reliable_qos(10))
        raw = B.Raw(peer, GripRecommendationSet, f"{ns}/grip_recommendation_sets")
        if not peer.spin_until(lambda: pub.get_subscription_count() > 0 and raw.sub.get_publisher_count() > 0, 15):
            print(json.dumps({"error": "no match on the set topics"}))
            return 1
        msg = serialize_message(B.set_message(B.candidates(args.n, 120624, "succession"), "succession"))
        # Raises, naming the set, when one is not answered within the timeout.
        trips = B.round_trips(peer, lambda: pub.publish(msg), raw, args.sets, 0, timeout=args.timeout)
        print(json.dumps({"bytes": len(msg), "trips_s": trips}))
        return 0
    finally:
        peer.destroy()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
