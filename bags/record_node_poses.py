#!/usr/bin/env python3
"""Records bags/node_poses.mcap with `grasp_orient node` itself: pose candidates and pose sets (docs/poses.md)
through the code path users run (see bags/README.md).

    cargo build --profile test && source "$(bash tests/peer/setup.sh | tail -n 1)" && python bags/record_node_poses.py [--bin PATH] [--out PATH]

The node runs in namespace /golden with record_markers:=true. From rclpy (Fast DDS, on a private ROS domain) it is
sent, one at a time, each answer awaited, the pose candidates and pose sets of tests/ros/pose_cases.py: every grasp
on a block given inline, on the same block named by package://grasp_orient/meshes/block_mm.obj (found through
AMENT_PREFIX_PATH, which the peer's environment sets to its install of this package, meshes/ included), and on
the four primitives; refused ones (a finger closing on nothing, a finger starting inside, a scale of 0, a
primitive with a scale, an unknown primitive type); the sets on pose_candidate_sets, and the first set once more
through the service ~/recommend_poses (with another id). SIGINT ends the node, which closes the file; it is copied
to --out.

Header stamps are fixed; log and publish times are the real ones of the run, so a rerun writes other bytes with
the same messages. Rerun it when the node's recording format or the answers change.
"""
from __future__ import annotations

import argparse
import copy
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent
sys.path.insert(0, str(REPO_ROOT / "tests" / "ros"))
sys.path.insert(0, str(HERE))

import node_run  # noqa: E402
import pose_cases as pc  # noqa: E402
from node_run import NODE, NS  # noqa: E402


def die(msg: str):
    print(f"record_node_poses.py: {msg}", file=sys.stderr)
    sys.exit(1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", type=Path, default=REPO_ROOT / "target" / "debug" / "grasp_orient")
    ap.add_argument("--out", type=Path, default=HERE / "node_poses.mcap")
    args = ap.parse_args()
    node_run.use_private_domain()
    try:
        import rclpy
        from grasp_orient.msg import PoseCandidate, PoseCandidateSet, PoseRecommendation, PoseRecommendationSet
        from grasp_orient.srv import RecommendPoses
    except ImportError as e:
        die(f"cannot import rclpy / grasp_orient.msg ({e}); source \"$(bash tests/peer/setup.sh | tail -n 1)\" first")

    singles, sets = pc.singles(), pc.sets()
    by_service = copy.deepcopy(sets[0])
    by_service["id"] += "-service"
    with node_run.recording_node("record_node_poses.py", args.bin, args.out, ["-p", "record_markers:=true"]) as run:
        rclpy.init()
        node = rclpy.create_node("grasp_orient_record_node_poses")
        qos = node_run.reliable_qos(100)
        got: dict[str, object] = {}
        pub = node.create_publisher(PoseCandidate, f"{NS}/pose_candidates", qos)
        set_pub = node.create_publisher(PoseCandidateSet, f"{NS}/pose_candidate_sets", qos)
        node.create_subscription(PoseRecommendation, f"{NS}/pose_recommendations",
                                 lambda m: got.setdefault(m.recommendation.candidate_id, m), qos)
        node.create_subscription(PoseRecommendationSet, f"{NS}/pose_recommendation_sets",
                                 lambda m: got.setdefault(m.set_id, m), qos)
        run.spin_until(node, lambda: pub.get_subscription_count() and set_pub.get_subscription_count()
                       and node.count_publishers(f"{NS}/pose_recommendations")
                       and node.count_publishers(f"{NS}/pose_recommendation_sets"),
                       20, "no match with the node within 20 s")
        time.sleep(0.5)  # both directions discovered

        def await_answer(key: str):
            run.spin_until(node, lambda: key in got, 20,
                           lambda: f"no answer to {key} within 20 s:\n" + run.last_lines(20))

        for c in singles:
            pub.publish(pc.fill(PoseCandidate(), c))
            await_answer(c["id"])
        for s in sets:
            set_pub.publish(pc.fill(PoseCandidateSet(), s))
            await_answer(s["id"])
        client = node.create_client(RecommendPoses, f"{NODE}/recommend_poses")
        if not client.wait_for_service(timeout_sec=10):
            run.die(f"no {NODE}/recommend_poses service")
        req = RecommendPoses.Request()
        req.pose_set = pc.fill(PoseCandidateSet(), by_service)
        future = client.call_async(req)
        rclpy.spin_until_future_complete(node, future, timeout_sec=20)
        if not (future.done() and future.result().recommendation_set.set_id == by_service["id"]):
            run.die("no answer from the service")
        node.destroy_node()
        rclpy.shutdown()
    print(f"wrote {args.out}: {len(singles)} pose candidates and {len(sets) + 1} pose sets from {run.recorded}")


if __name__ == "__main__":
    main()
