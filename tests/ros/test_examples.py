"""examples/pick.py (docs/moveit.md) run as a user runs it, beside the node, over Fast DDS.

The node runs in a namespace of its own with gravity_frame world, examples/pick_objects.yaml as its objects_file
and gripper_action naming the action the script's --fake-gripper serves; it is stopped at the module's end (the
suite shares one pytest session). The script publishes its static tree and its box, ranks its grasps through
~/rank_grasps and sends the best to ~/grip; its last line is a JSON summary. The test takes the scene's numbers
from the script (its tree, box and grasp offsets, as data) and builds the equivalent PoseCandidates itself: the
grasp poses, the box's pose and gravity carried into the camera frame by homogeneous matrices composed in numpy
(tests/ros/tf_cases.py), which shares nothing with the script's quaternion arithmetic nor with the node's TF.
`grasp_orient solve` answers them; the script's ranking must be solve's (status 0, within max_grip_force, least
force first) with the same forces, and the goal its fake gripper received must carry the best grasp's force times
grip_safety_factor, capped by max_grip_force.
"""
from __future__ import annotations

import importlib.util
import json
import math
import time

import numpy as np
import pytest
import yaml

from conftest import DOMAIN_ID, REPO_ROOT, ros_env, run_python, run_solve
from tf_cases import GRAVITY, matrix_of, pose_of, tool_pose_gap, vec

PICK = REPO_ROOT / "examples" / "pick.py"
OBJECTS = REPO_ROOT / "examples" / "pick_objects.yaml"
NODE_NS = "/pick_case"
ACTION = f"{NODE_NS}/gripper_cmd"
FACTOR = 3.0  # with max_grip_force between the two largest forces, the best grasp's goal is capped
SCRIPT_TIMEOUT = 30.0


def example():
    """examples/pick.py as a module, for its scene's numbers (its main() is not run)."""
    spec = importlib.util.spec_from_file_location("pick_example", PICK)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """tf2's setRPY: about the fixed x, then y, then z, as matrices Rz Ry Rx."""
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def edge(t, rpy) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rpy_matrix(*rpy)
    m[:3, 3] = t
    return m


def in_world(ex, frame: str) -> np.ndarray:
    """T_world_frame: the script's tree's edges from the gravity frame down to `frame`, composed."""
    if frame == ex.GRAVITY_FRAME:
        return np.eye(4)
    parent, t, rpy = next((p, t, rpy) for p, child, t, rpy in ex.TREE if child == frame)
    return in_world(ex, parent) @ edge(t, rpy)


def camera_in_world(ex) -> np.ndarray:
    return in_world(ex, ex.CAMERA_FRAME)


def expected_candidates(ex) -> list[dict]:
    """The script's grasps as PoseCandidates in the camera frame, by numpy."""
    camera = camera_in_world(ex)
    box = np.linalg.inv(camera) @ in_world(ex, ex.BOX_FRAME) @ edge(ex.BOX_POSITION, ex.BOX_RPY)
    entry = yaml.safe_load(OBJECTS.read_text())["objects"][ex.BOX_ID]
    obj = {"pose": pose_of(box), "scale": {"x": 1.0, "y": 1.0, "z": 1.0}, "mass": float(entry["mass"]),
           "friction": float(entry["friction"]), "primitive": {"type": 1, "dimensions": list(ex.BOX_SIZE)}}
    gravity = vec(camera[:3, :3].T @ GRAVITY)
    return [{"header": {"frame_id": ex.CAMERA_FRAME, "stamp": {"sec": 0, "nanosec": 0}}, "id": gid,
             "grasp_pose": pose_of(box @ edge(t, rpy)), "width": ex.WIDTH, "object": obj, "gravity": gravity}
            for gid, t, rpy in ex.GRASPS]


@pytest.fixture(scope="module")
def case():
    """solve's answers on the equivalent candidates, and max_grip_force put between the two largest forces held,
    so that the gripper's limit leaves one grasp out."""
    ex = example()
    cands = expected_candidates(ex)
    answers = {c["id"]: a for c, a in zip(cands, run_solve(cands))}
    held = sorted((a["recommendation"]["internal_force"], i) for i, a in answers.items()
                  if a["recommendation"]["status"] == 0)
    assert len(held) >= 4, f"solve holds only {len(held)} of the example's grasps: {answers}"
    limit = float(f"{(held[-2][0] + held[-1][0]) / 2:.9f}")
    return {"example": ex, "solve": answers, "held": held, "limit": limit, "camera_in_world": camera_in_world(ex)}


@pytest.fixture(scope="module")
def pick_node(start_node, case):
    n = start_node("--ros-args", "-r", f"__ns:={NODE_NS}", "-p", "gravity_frame:=world", "-p", "tf_timeout:=0.5",
                   "-p", f"objects_file:={OBJECTS}", "-p", f"gripper_action:={ACTION}",
                   "-p", f"grip_safety_factor:={FACTOR}", "-p", f"max_grip_force:={case['limit']:.9f}",
                   "-p", "grip_timeout:=2.0", "-p", "record:=false", name="grasp_orient node (pick example)")
    yield n
    if n.proc.poll() is None:
        n.stop_and_check()


def run_pick(*args: str):
    return run_python([str(PICK), "--ns", NODE_NS, "--action", ACTION, "--timeout", str(SCRIPT_TIMEOUT), *args],
                      ros_env(DOMAIN_ID), timeout=SCRIPT_TIMEOUT + 30)


def summary_of(r) -> dict:
    lines = r.stdout.strip().splitlines()
    assert lines, f"the script printed nothing; stderr:\n{r.stderr}"
    return json.loads(lines[-1])


def test_the_pick_example_ranks_as_solve_and_the_gripper_gets_the_force(case, pick_node):
    r = run_pick("--fake-gripper")
    assert r.returncode == 0, f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}"
    got = summary_of(r)
    solve = case["solve"]
    want = [i for f, i in case["held"] if f <= case["limit"]]
    assert [g["id"] for g in got["ranked"]] == want, (got["ranked"], case["held"], case["limit"])
    assert len(want) == len(case["held"]) - 1, "the limit leaves out one grasp held"
    for g in got["ranked"]:
        force = solve[g["id"]]["recommendation"]["internal_force"]
        assert math.isclose(g["internal_force"], force, rel_tol=1e-9, abs_tol=1e-12), (g, force)
        assert g["max_contact_force"] == float(np.float32(g["internal_force"])), g
        assert abs(g["grasp_quality"] - got["ranked"][0]["internal_force"] / g["internal_force"]) <= 1e-12, g
        now = solve[g["id"]]["recommendation"]["internal_force_current"]  # None where inf
        assert (g["internal_force_current"] is None) == (now is None), (g, now)
        assert now is None or math.isclose(g["internal_force_current"], now, rel_tol=1e-9, abs_tol=1e-12), (g, now)
        assert math.isclose(g["wrist_rotation"], solve[g["id"]]["recommendation"]["wrist_rotation"], rel_tol=1e-9,
                            abs_tol=1e-9), (g, solve[g["id"]]["recommendation"])
        # The tool pose in world: solve's, in the camera frame, carried into world by numpy.
        tp = g["tool_pose"]
        assert tp["frame_id"] == "world", g
        tool_in_world = case["camera_in_world"] @ matrix_of(solve[g["id"]]["tool_pose"]["pose"])
        got_pose = {"position": dict(zip("xyz", tp["position"])), "orientation": dict(zip("xyzw", tp["orientation"]))}
        assert tool_pose_gap(got_pose, tool_in_world) <= 1e-9, (g["id"], tp, tool_in_world)
    over = case["held"][-1][1]
    left_out = {n["id"]: n for n in got["not_ranked"]}
    assert left_out[over]["status"] == 3, left_out
    for i, a in solve.items():
        if a["recommendation"]["status"] != 0:
            assert left_out[i]["status"] == a["recommendation"]["status"], (i, left_out.get(i), a)
    best = got["ranked"][0]
    assert got["best"] == best["id"] and got["recommended_force"] == best["internal_force"], got
    sent = min(best["internal_force"] * FACTOR, case["limit"])
    assert sent < best["internal_force"] * FACTOR, "the case should have the cap cut the force sent"
    assert got["force_sent"] == sent and got["gripper_max_effort"] == sent, (got, sent)
    assert math.isclose(sent, min(solve[best["id"]]["recommendation"]["internal_force"] * FACTOR, case["limit"]),
                        rel_tol=1e-9)
    assert got["sent"] and got["goal_status"] == 4 and got["action"] == ACTION and got["gripper_goals"] == 1, got
    assert f"fake gripper {ACTION}: goal" in r.stdout and f"command.max_effort {sent:.6g} N" in r.stdout, r.stdout


def test_without_a_gripper_the_ranking_still_prints_and_the_grip_fails_clearly(case, pick_node):
    """No --fake-gripper and no controller: the ranking is printed, the grip is refused in the node's words
    (no server within grip_timeout), and the script exits 1."""
    r = run_pick()
    assert r.returncode == 1, f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}"
    got = summary_of(r)
    assert [g["id"] for g in got["ranked"]] == [i for f, i in case["held"] if f <= case["limit"]], got
    assert not got["sent"] and got["gripper_max_effort"] is None, got
    assert f"no action server at {ACTION}" in r.stderr, r.stderr


def test_no_node_is_a_clear_error_within_the_timeout():
    t0 = time.monotonic()
    r = run_python([str(PICK), "--ns", "/nobody_here", "--timeout", "2"], ros_env(DOMAIN_ID), timeout=60)
    assert r.returncode == 1, (r.returncode, r.stdout, r.stderr)
    assert "/nobody_here/grasp_orient/rank_grasps" in r.stderr and f"ROS_DOMAIN_ID={DOMAIN_ID}" in r.stderr, r.stderr
    assert time.monotonic() - t0 < 30
