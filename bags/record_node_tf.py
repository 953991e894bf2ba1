#!/usr/bin/env python3
"""Records bags/node_tf.mcap with `grasp_orient node` itself, gravity and object poses taken from TF (docs/node.md#tf),
through the code path users run (see bags/README.md).

    cargo build --profile test && source "$(bash tests/peer/setup.sh | tail -n 1)" && python bags/record_node_tf.py [--bin PATH] [--out PATH]

The node runs in namespace /golden with gravity_frame:=world and record_markers:=true. From rclpy (Fast DDS, on a
private ROS domain) the script publishes, as tf2_ros's broadcasters do, three random frame trees below world (static
transforms on /tf_static, transient-local; one moving transform per tree at two stamps on /tf), and then sends, one
at a time, each answer awaited: 12 grasp candidates in frames of the trees, at stamps between the moving
transforms' two samples or 0 (the latest); 6 pose candidates whose object pose is given in another frame of the
tree; a candidate set on grasp_candidate_sets whose members are in several frames; a pose set through
~/recommend_poses, its object in another frame. Every one is answered turned by TF (the script ends if one is
refused for its transforms), so the recording holds each request as the node answered it: gravity turned into
the request's frame and the object's pose into its header frame, object.frame_id empty. `replay` then needs no TF.
SIGINT ends the node, which closes the file; it is copied to --out.

The trees and requests are seeded; log and publish times are those of the run, so a rerun writes other bytes with
the same requests. Rerun it when the node's recording format or the answers change.
"""
from __future__ import annotations

import argparse
import random
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent
sys.path.insert(0, str(REPO_ROOT / "tests" / "ros"))
sys.path.insert(0, str(HERE))

import node_run  # noqa: E402
import pose_cases as pc  # noqa: E402
from mcap_util import random_grasp  # noqa: E402
from node_run import NODE, NS  # noqa: E402
from tf_cases import NS as SECOND, T1, T2, Tree, homogeneous, pose_of, random_quaternion, stamp_of, transform_msg  # noqa: E402,E501

SEED = 20261207
BOX = {"type": 1, "dimensions": [0.04, 0.06, 0.08]}
ONE = {"x": 1.0, "y": 1.0, "z": 1.0}
PLACEHOLDER = {"x": 0.0, "y": 0.0, "z": -1.0}  # replaced by the node: gravity comes from gravity_frame


def stamp(rng: random.Random) -> int:
    """Between the moving transforms' two samples, or 0 (the latest) one time in four."""
    return 0 if rng.random() < 0.25 else rng.randrange(T1 + 1, T2)


def object_in(tree: Tree, rng: random.Random, frame: str, object_frame: str, at: int) -> tuple[dict, dict]:
    """An object near `frame`'s origin, turned at random: (its pose in `frame`, its pose in `object_frame`), both at
    stamp `at`."""
    import numpy as np
    in_header = homogeneous([rng.uniform(-0.3, 0.3) for _ in range(3)], random_quaternion(rng))
    in_its_frame = np.linalg.inv(tree.in_world(object_frame, at)) @ tree.in_world(frame, at) @ in_header
    return in_header, pose_of(in_its_frame)


def requests(rng: random.Random, trees: list[Tree]):
    """(grasp candidates, pose candidates, a candidate set, a pose set) as JSON dicts."""
    import numpy as np
    grasps = []
    for k in range(12):
        tr = trees[k % len(trees)]
        at = stamp(rng)
        grasps.append(random_grasp(rng, f"tf-grasp-{k}", rng.choice(tr.frames[1:]), (at // SECOND, at % SECOND)))
    poses = []
    for k in range(6):
        tr = trees[k % len(trees)]
        frame = rng.choice(tr.frames[1:])
        object_frame = rng.choice([f for f in tr.frames if f != frame])
        at = stamp(rng)
        in_header, given = object_in(tr, rng, frame, object_frame, at)
        poses.append({"header": {"frame_id": frame, "stamp": stamp_of(at)}, "id": f"tf-pose-{k}",
                      "grasp_pose": pose_of(in_header), "width": 0.09,
                      "object": {"pose": given, "frame_id": object_frame, "primitive": BOX, "scale": ONE,
                                 "mass": round(rng.uniform(0.1, 2.0), 6), "friction": round(rng.uniform(0.3, 1.0), 6)},
                      "gravity": PLACEHOLDER})
    members = []
    for k in range(8):
        tr = trees[k % len(trees)]
        at = stamp(rng)
        members.append(random_grasp(rng, f"tf-member-{k}", rng.choice(tr.frames[1:]), (at // SECOND, at % SECOND)))
    cset = {"header": {"frame_id": "world", "stamp": stamp_of(0)}, "id": "tf-set", "candidates": members}
    tr = trees[0]
    frame, object_frame = tr.frames[-1], tr.frames[1]
    at = (T1 + T2) // 2
    in_header, given = object_in(tr, rng, frame, object_frame, at)
    turns = [homogeneous([dx, 0.0, 0.0], [0.0, 0.0, float(np.sin(a / 2)), float(np.cos(a / 2))])
             for dx, a in [(0.0, 0.0), (0.005, 0.0), (0.0, np.pi / 2), (0.01, 0.3)]]
    pset = {"header": {"frame_id": frame, "stamp": stamp_of(at)}, "id": "tf-pose-set",
            "object": {"pose": given, "frame_id": object_frame, "primitive": BOX, "scale": ONE, "mass": 0.4,
                       "friction": 0.6},
            "poses": [{"id": f"p{k}", "grasp_pose": pose_of(in_header @ t), "width": 0.09} for k, t in enumerate(turns)],
            "gravity": PLACEHOLDER}
    return grasps, poses, cset, pset


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", type=Path, default=REPO_ROOT / "target" / "debug" / "grasp_orient")
    ap.add_argument("--out", type=Path, default=HERE / "node_tf.mcap")
    args = ap.parse_args()
    node_run.use_private_domain()
    try:
        import rclpy
        from grasp_orient.msg import (
            GraspCandidate, GraspCandidateSet, GripRecommendation, GripRecommendationSet, PoseCandidate,
            PoseCandidateSet, PoseRecommendation,
        )
        from grasp_orient.srv import RecommendPoses
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from tf2_msgs.msg import TFMessage
    except ImportError as e:
        die(f"cannot import rclpy / grasp_orient.msg / tf2_msgs.msg ({e}); "
            "source \"$(bash tests/peer/setup.sh | tail -n 1)\" first")

    rng = random.Random(SEED)
    trees = [Tree(rng, k) for k in range(3)]
    grasps, poses, cset, pset = requests(rng, trees)
    params = ["-p", "gravity_frame:=world", "-p", "tf_timeout:=2.0", "-p", "record_markers:=true"]
    with node_run.recording_node("record_node_tf.py", args.bin, args.out, params) as run:
        rclpy.init()
        node = rclpy.create_node("grasp_orient_record_node_tf")
        qos = node_run.reliable_qos(100)
        # tf2_ros's StaticBroadcasterQoS and DynamicBroadcasterQoS.
        static_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
        tf_static = node.create_publisher(TFMessage, "/tf_static", static_qos)
        tf = node.create_publisher(TFMessage, "/tf", node_run.reliable_qos(100))
        got: dict[str, object] = {}
        pub = node.create_publisher(GraspCandidate, f"{NS}/grasp_candidates", qos)
        pose_pub = node.create_publisher(PoseCandidate, f"{NS}/pose_candidates", qos)
        set_pub = node.create_publisher(GraspCandidateSet, f"{NS}/grasp_candidate_sets", qos)
        node.create_subscription(GripRecommendation, f"{NS}/grip_recommendations",
                                 lambda m: got.setdefault(m.candidate_id, m), qos)
        node.create_subscription(PoseRecommendation, f"{NS}/pose_recommendations",
                                 lambda m: got.setdefault(m.recommendation.candidate_id, m.recommendation), qos)
        node.create_subscription(GripRecommendationSet, f"{NS}/grip_recommendation_sets",
                                 lambda m: got.setdefault(m.set_id, m), qos)
        writers = [tf_static, tf, pub, pose_pub, set_pub]
        answers = [f"{NS}/grip_recommendations", f"{NS}/pose_recommendations", f"{NS}/grip_recommendation_sets"]
        run.spin_until(node, lambda: all(w.get_subscription_count() for w in writers)
                       and all(node.count_publishers(a) for a in answers), 20, "no match with the node within 20 s")
        time.sleep(0.5)  # both directions discovered

        tf_static.publish(TFMessage(transforms=[transform_msg(tr.parent[f], f, 0, *tr.static[f])
                                                for tr in trees for f in tr.static]))
        for i in (0, 1):
            tf.publish(TFMessage(transforms=[transform_msg(tr.parent[tr.moving], tr.moving, *tr.samples[i])
                                             for tr in trees]))

        def await_answer(key: str):
            run.spin_until(node, lambda: key in got, 20, lambda: f"no answer to {key} within 20 s:\n" + run.last_lines(20))
            status, message = got[key].status, got[key].message
            if "no transform" in message:
                run.die(f"{key} was refused for its transforms (status {status}): {message}")

        for c in grasps:
            m = GraspCandidate()
            pc.fill(m, c)
            pub.publish(m)
            await_answer(c["id"])
        for c in poses:
            pose_pub.publish(pc.fill(PoseCandidate(), c))
            await_answer(c["id"])
        set_pub.publish(pc.fill(GraspCandidateSet(), cset))
        await_answer(cset["id"])
        client = node.create_client(RecommendPoses, f"{NODE}/recommend_poses")
        if not client.wait_for_service(timeout_sec=10):
            run.die(f"no {NODE}/recommend_poses service")
        req = RecommendPoses.Request()
        req.pose_set = pc.fill(PoseCandidateSet(), pset)
        future = client.call_async(req)
        rclpy.spin_until_future_complete(node, future, timeout_sec=20)
        if not future.done():
            run.die("no answer from ~/recommend_poses")
        answer = future.result().recommendation_set
        if answer.set_id != pset["id"] or answer.status != 0 or not answer.ranking:
            run.die(f"~/recommend_poses: status {answer.status}, {answer.message!r}, ranking {list(answer.ranking)}")
        node.destroy_node()
        rclpy.shutdown()
    print(f"wrote {args.out}: {len(grasps)} candidates, {len(poses)} pose candidates, a set of {len(cset['candidates'])} "
          f"and a pose set of {len(pset['poses'])} in {len(trees)} frame trees, from {run.recorded}")


def die(msg: str):
    print(f"record_node_tf.py: {msg}", file=sys.stderr)
    sys.exit(1)


if __name__ == "__main__":
    main()
