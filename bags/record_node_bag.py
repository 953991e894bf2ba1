#!/usr/bin/env python3
"""Records bags/node_recorded.mcap with `grasp_orient node` itself: the code path users run (see bags/README.md).

    source "$(bash tests/peer/setup.sh | tail -n 1)" && python bags/record_node_bag.py [--bin PATH] [--out PATH]

The node runs in namespace /golden with record_markers:=true, range:=graspable and friction_safety_factor:=1.25.
From rclpy (Fast DDS, on a private ROS domain) it is sent, one at a time, each answer awaited:
  1. the paper's 4 cases (examples/paper_cases.jsonl), ids golden-paper-a..d;
  2. the 30 refused and unclosed candidates of bags/make_bags.py (NaN and infinite fields, out-of-range values,
     degenerate geometry, overlong id and frame_id, 3 without force closure);
then objective is set to norm1 through the parameter service, and
  3. the 4 paper cases again, ids golden-paper-a..d-norm1.
SIGINT ends the node, which closes the file; it is copied to --out. So the bag holds 38 candidates, their 38
answers, a marker array for each solved one, and 2 settings records (at start, and at the objective change).

Candidate header stamps are fixed (2025-01-01T00:00:00Z + k * 10 ms); log and publish times are the real ones of
the run, so a rerun writes different bytes with the same messages. Rerun it when the node's recording format or
the solver's answers change.
"""
from __future__ import annotations

import argparse
import json
import random
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO_ROOT = HERE.parent
sys.path.insert(0, str(REPO_ROOT / "tests" / "ros"))
sys.path.insert(0, str(HERE))

import mcap_util as mu  # noqa: E402
import make_bags  # noqa: E402
import node_run  # noqa: E402
from node_run import NODE, NS  # noqa: E402

T0 = 1_735_689_600_000_000_000  # 2025-01-01T00:00:00Z
PERIOD = 10_000_000


def die(msg: str):
    print(f"record_node_bag.py: {msg}", file=sys.stderr)
    sys.exit(1)


def candidates() -> tuple[list[dict], list[dict]]:
    """(sent before the parameter change, sent after it)."""
    paper = mu.load_paper_cases()
    for k, c in enumerate(paper):
        c["id"] = "golden-" + c["id"]
        c["header"]["stamp"] = make_bags.stamp_of(T0 + k * PERIOD)
    refused = [c for _, _, c in make_bags.refused_candidates(random.Random(make_bags.SEED), T0 + 4 * PERIOD)]
    again = json.loads(json.dumps(paper))
    for k, c in enumerate(again):
        c["id"] += "-norm1"
        c["header"]["stamp"] = make_bags.stamp_of(T0 + (40 + k) * PERIOD)
    return paper + refused, again


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", type=Path, default=REPO_ROOT / "target" / "debug" / "grasp_orient")
    ap.add_argument("--out", type=Path, default=HERE / "node_recorded.mcap")
    args = ap.parse_args()
    node_run.use_private_domain()
    try:
        import rclpy
        from grasp_orient.msg import GraspCandidate, GripRecommendation
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters
    except ImportError as e:
        die(f"cannot import rclpy / grasp_orient.msg ({e}); source \"$(bash tests/peer/setup.sh | tail -n 1)\" first")

    before, after = candidates()
    params = ["-p", "record_markers:=true", "-p", "range:=graspable", "-p", "friction_safety_factor:=1.25"]
    with node_run.recording_node("record_node_bag.py", args.bin, args.out, params) as run:
        rclpy.init()
        node = rclpy.create_node("grasp_orient_record_node_bag")
        qos = node_run.reliable_qos(1000)
        got: dict[str, object] = {}
        pub = node.create_publisher(GraspCandidate, f"{NS}/grasp_candidates", qos)
        node.create_subscription(GripRecommendation, f"{NS}/grip_recommendations",
                                 lambda m: got.setdefault(m.candidate_id, m), qos)
        run.spin_until(node, lambda: pub.get_subscription_count()
                       and node.count_publishers(f"{NS}/grip_recommendations"),
                       20, "no match with the node within 20 s")
        time.sleep(0.5)  # both directions discovered

        def send(cands: list[dict]):
            for c in cands:
                m = GraspCandidate()
                make_bags.fill(m, c)
                pub.publish(m)
                run.spin_until(node, lambda: c["id"][:1024] in got, 10,
                               lambda: f"no answer to {c['id'][:40]} within 10 s:\n" + run.last_lines(20))

        send(before)
        client = node.create_client(SetParameters, f"{NODE}/set_parameters")
        if not client.wait_for_service(timeout_sec=10):
            run.die(f"no {NODE}/set_parameters service")
        value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="norm1")
        future = client.call_async(SetParameters.Request(parameters=[Parameter(name="objective", value=value)]))
        rclpy.spin_until_future_complete(node, future, timeout_sec=10)
        if not (future.done() and future.result().results[0].successful):
            run.die("objective:=norm1 was not accepted")
        send(after)
        node.destroy_node()
        rclpy.shutdown()
    print(f"wrote {args.out}: {len(before) + len(after)} candidates from {run.recorded}")


if __name__ == "__main__":
    main()
