#!/usr/bin/env python3
"""Send one grasp to a running grasp_orient node and print its recommendation.

    source "$(bash tests/peer/setup.sh | tail -n 1)"       # rclpy + grasp_orient.msg (once)
    target/debug/grasp_orient node &                          # the node, same ROS_DOMAIN_ID
    python examples/publish_test_grasp.py                     # paper case (a)
    python examples/publish_test_grasp.py my_grasp.json       # a GraspCandidate as JSON (or JSON lines: each one)
    python examples/publish_test_grasp.py --ns /robot1        # a node started with -r __ns:=/robot1

The JSON form is that of `grasp_orient solve`: the fields of msg/GraspCandidate.msg in snake_case, points and
vectors as {"x":..,"y":..,"z":..}, header optional. Exit status: 0 when every grasp was answered (whatever its
status), 1 when no answer came within the timeout (10 s) or the input is unreadable.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

PAPER_CASE_A = {
    "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "object"},
    "id": "paper-a",
    "contact_1": {"x": 0.08660254037844385, "y": 0.05, "z": 0.0},
    "contact_2": {"x": -0.08660254037844385, "y": 0.05, "z": 0.0},
    "normal_1": {"x": -0.8660254037844386, "y": -0.5000000000000001, "z": 0.0},
    "normal_2": {"x": 0.8660254037844386, "y": -0.5000000000000001, "z": 0.0},
    "friction_1": 1.5,
    "friction_2": 1.0,
    "center_of_mass": {"x": 0.0, "y": 0.0, "z": 0.0},
    "mass": 0.10197162129779283,
    "gravity": {"x": 0.0, "y": -9.80665, "z": 0.0},
}

STATUS = {0: "OK", 1: "NO_FORCE_CLOSURE", 2: "INVALID_INPUT"}
CANDIDATE_C = {0: "recommended (Theorem 1 holds)", 1: "not a local minimum", 2: "beaten by another point",
               3: "out of range"}


def fail(msg: str) -> int:
    print(f"publish_test_grasp: {msg}", file=sys.stderr)
    return 1


def read_candidates(path: str | None) -> list[dict]:
    if path is None:
        return [dict(PAPER_CASE_A)]
    text = open(path, encoding="utf-8").read()
    try:
        data = json.loads(text)
        items = data if isinstance(data, list) else [data]
    except json.JSONDecodeError:
        items = [json.loads(line) for line in text.splitlines() if line.strip()]
    if not items or not all(isinstance(c, dict) for c in items):
        raise ValueError(f"{path}: expected a JSON object (or JSON lines of objects)")
    for k, c in enumerate(items):
        c.setdefault("id", f"{os.path.basename(path)}:{k + 1}")
    return items


def fill(msg, data: dict):
    for k, v in data.items():
        if not hasattr(msg, k):
            raise ValueError(f"unknown field {k!r} in {type(msg).__name__}")
        if isinstance(v, dict):
            fill(getattr(msg, k), v)
        else:
            setattr(msg, k, float(v) if isinstance(getattr(msg, k), float) and isinstance(v, int) else v)
    return msg


def fmt(x: float, unit: str = "", digits: int = 6) -> str:
    if not math.isfinite(x):
        return str(x)
    return f"{x:.{digits}g}{(' ' + unit) if unit else ''}"


def describe(ans) -> str:
    lines = [f"candidate {ans.candidate_id!r} (frame {ans.header.frame_id!r}): "
             f"status {ans.status} {STATUS.get(ans.status, '?')}"]
    if ans.message:
        lines.append(f"  message:           {ans.message}")
    if ans.status == 0:
        lines += [
            f"  objective:         {ans.objective}",
            f"  wrist rotation:    {fmt(ans.wrist_rotation, 'rad')} = {fmt(math.degrees(ans.wrist_rotation), 'deg', 5)}"
            f"  (counter-clockwise about +z of {ans.header.frame_id!r})",
            f"  gravity afterwards: ({fmt(ans.gravity_direction.x, '', 4)}, {fmt(ans.gravity_direction.y, '', 4)})"
            f" in that frame",
            f"  internal force:    {fmt(ans.internal_force, 'N')}   (now: {fmt(ans.internal_force_current, 'N')})",
            f"  gripping power:    {fmt(ans.gripping_power, 'N')}   (now: {fmt(ans.gripping_power_current, 'N')})",
            "  contact forces:    N1 {} F1 {} N2 {} F2 {} (N)".format(*(fmt(f, '', 5) for f in ans.contact_forces)),
            f"  case / label:      {ans.grasp_case or '-'} / {ans.recommended_label or '-'};"
            f" the paper's candidate C: {CANDIDATE_C.get(ans.candidate_c, ans.candidate_c)}",
        ]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", help="GraspCandidate as JSON (default: the paper's case (a))")
    ap.add_argument("--ns", default="", help="namespace of the node (e.g. /robot1)")
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for every answer (10)")
    args = ap.parse_args()

    try:
        import rclpy
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from grasp_orient.msg import GraspCandidate, GripRecommendation
    except ImportError as e:
        return fail(f"{e}: source the ROS peer first (source \"$(bash tests/peer/setup.sh | tail -n 1)\")")

    try:
        cands = read_candidates(args.file)
        msgs = [fill(GraspCandidate(), c) for c in cands]
    except (OSError, ValueError, TypeError, AttributeError) as e:
        return fail(f"cannot read the candidate: {e}")

    ns = args.ns.rstrip("/")
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    rclpy.init()
    try:
        node = rclpy.create_node("publish_test_grasp")
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                         durability=DurabilityPolicy.VOLATILE)
        answers: dict[str, object] = {}
        sub = node.create_subscription(GripRecommendation, f"{ns}/grip_recommendations",
                                       lambda m: answers.setdefault(m.candidate_id, m), qos)
        pub = node.create_publisher(GraspCandidate, f"{ns}/grasp_candidates", qos)

        deadline = time.monotonic() + args.timeout
        # Wait until the node's subscriber and publisher are matched, so that nothing is sent into the void.
        while time.monotonic() < deadline and not (pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0):
            rclpy.spin_once(node, timeout_sec=0.05)
        if not (pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0):
            return fail(f"no grasp_orient node found on {ns}/grasp_candidates and {ns}/grip_recommendations within "
                        f"{args.timeout:g} s: is grasp_orient node running on ROS_DOMAIN_ID={domain}?")

        def answered(i: int) -> bool:
            # the node cuts ids over 1024 bytes in its answer
            cid = msgs[i].id
            return cid in answers or any(cid.startswith(a) and a for a in answers if len(cid) > 1024)

        resend_at = time.monotonic() + 1.0
        for m in msgs:
            pub.publish(m)
        while time.monotonic() < deadline and not all(answered(i) for i in range(len(msgs))):
            rclpy.spin_once(node, timeout_sec=0.05)
            if time.monotonic() > resend_at:  # the node's answer writer may have matched us after the first send
                for i, m in enumerate(msgs):
                    if not answered(i):
                        pub.publish(m)
                resend_at = time.monotonic() + 1.0
        shown = set()
        for i, m in enumerate(msgs):
            if not answered(i):
                continue
            a = answers.get(m.id) or next(a for k, a in answers.items() if m.id.startswith(k) and k)
            if id(a) not in shown:
                shown.add(id(a))
                print(describe(a))
        missing = [m.id for i, m in enumerate(msgs) if not answered(i)]
        if missing:
            return fail(f"no answer within {args.timeout:g} s for {missing[:5]}: is grasp_orient node running on "
                        f"ROS_DOMAIN_ID={domain} (namespace {ns or '/'})?")
        node.destroy_node()
        return 0
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
