"""The service ~/grip (docs/node.md#grip) against rclpy action servers of control_msgs over Fast DDS.

control_msgs is built by tests/peer/setup.sh from its Jazzy definitions (GripperCommand.msg, GripperCommand.action,
ParallelGripperCommand.action, verbatim). An rclpy `ActionServer` of control_msgs/action/GripperCommand, as
ros2_control's gripper controllers offer it, receives the node's goal: its command.max_effort must be the grip
force of the node's own answer (internal_force, gripper_drive coupled) times grip_safety_factor, capped by
max_grip_force, and that grip force must equal `grasp_orient solve`'s on the same candidate; the response
carries the server's result. The same for a ParallelGripperCommand server (every joint of
parallel_gripper_joints at grip_position with the force as its effort), and a member of an answered set. The bad
cases each get a clear refusal and the node goes on: an unknown id, an answer with status 2 and one with status 3,
no gripper action set, no server at the action's name, a goal rejected, a goal without a result in grip_timeout
(canceled); and while a goal runs, the node keeps answering candidates.

Each node runs in a namespace of its own and is stopped at the module's end: the suite shares one pytest session.
"""
from __future__ import annotations

import copy
import math
import random
from pathlib import Path

import pytest

from conftest import GraspClient, Peer, reliable_qos, run_solve
from fake_action import FakeActionServer
from mcap_util import random_grasp
import pose_cases as pc

from control_msgs.action import GripperCommand, ParallelGripperCommand  # noqa: E402
from grasp_orient.msg import GraspCandidateSet, PoseCandidate, PoseRecommendation  # noqa: E402
from grasp_orient.srv import Grip, Recommend  # noqa: E402
from ament_index_python.packages import get_package_share_directory  # noqa: E402

JAZZY = Path(__file__).resolve().parent.parent.parent / "src" / "msg" / "jazzy"

NODE_NS = "/grip_case"
PARALLEL_NS = "/grip_parallel"
NONE_NS = "/grip_none"
ABSENT_NS = "/grip_absent"
FACTOR = 1.5
GRIP_TIMEOUT = 5.0  # the default: room for discovery on a loaded machine
POSITION = 0.01
JOINTS = ["left_finger_joint", "right_finger_joint"]
SUCCEEDED, CANCELED = 4, 5


def test_the_definitions_the_node_is_checked_against_are_the_peers():
    """src/msg/jazzy/ holds the texts the node's wire structs are held to (src/node/grip/wire.rs): control_msgs'
    as the peer built them, sensor_msgs/JointState as the ros-sensor-msgs wheel (Jazzy) installs it."""
    for package, files in (("control_msgs", ["msg/GripperCommand.msg", "action/GripperCommand.action",
                                              "action/ParallelGripperCommand.action"]),
                           ("sensor_msgs", ["msg/JointState.msg"])):
        share = Path(get_package_share_directory(package))
        for f in files:
            ours = (JAZZY / package / Path(f).name).read_text()
            assert (share / f).read_text() == ours, f"{package}/{f} differs from src/msg/jazzy/{package}/"


def candidates() -> dict[str, dict]:
    """Random grasps answered by `solve` (every one with status 0 and no limit), by id."""
    rng = random.Random(4242)
    return {c["id"]: c for c in (random_grasp(rng, f"grip-{k}", "object") for k in range(40))}


@pytest.fixture(scope="module")
def cases():
    """The candidates, solve's answers, and max_grip_force chosen between them: `capped` needs less than the
    limit but more once times FACTOR, `free` stays below it even times FACTOR, `over` needs more (status 3)."""
    cands = candidates()
    answers = {c["id"]: a for c, a in zip(cands.values(), run_solve(cands.values()))}
    ok = sorted((a["internal_force"], i) for i, a in answers.items() if a["status"] == 0)
    assert len(ok) >= 20, f"only {len(ok)} of the random grasps are answered with status 0"
    limit = float(f"{1.2 * ok[len(ok) // 2][0]:.9f}")  # written without an exponent, read back the same
    capped = next(i for f, i in ok if limit / FACTOR < f < limit)
    free = next(i for f, i in ok if f * FACTOR < 0.9 * limit)
    over = next(i for f, i in ok if f > limit)
    return {"cands": cands, "solve": answers, "limit": limit, "capped": capped, "free": free, "over": over}


def start(start_node, ns: str, *params: str, name: str):
    args = ["--ros-args", "-r", f"__ns:={ns}", "-p", "record:=false"]
    for p in params:
        args += ["-p", p]
    return start_node(*args, name=name)


@pytest.fixture(scope="module")
def nodes(start_node, cases):
    """Four nodes: GripperCommand at NODE_NS/gripper_cmd; ParallelGripperCommand at PARALLEL_NS/gripper_cmd; no
    gripper action; a GripperCommand name no server offers."""
    limit = f"max_grip_force:={cases['limit']:.9f}"
    started = [
        start(start_node, NODE_NS, "gripper_action:=gripper_cmd", f"grip_safety_factor:={FACTOR}", limit,
              f"grip_timeout:={GRIP_TIMEOUT}", f"grip_position:={POSITION}", name="grasp_orient node (gripper)"),
        start(start_node, PARALLEL_NS, f"parallel_gripper_action:={PARALLEL_NS}/gripper_cmd",
              f"parallel_gripper_joints:=[{', '.join(JOINTS)}]", f"grip_safety_factor:={FACTOR}",
              f"grip_position:={POSITION}", name="grasp_orient node (parallel gripper)"),
        start(start_node, NONE_NS, name="grasp_orient node (no gripper)"),
        start(start_node, ABSENT_NS, "gripper_action:=nobody_home", "grip_timeout:=0.5",
              name="grasp_orient node (absent gripper)"),
    ]
    yield started
    for n in started:
        n.stop_and_check()


class Gripper(FakeActionServer):
    """An rclpy action server of `action_type` at `name`, like a ros2_control gripper controller: it records each
    goal, accepts it (or rejects it while `reject` is set), and ends it at once with the commanded position and
    effort, stalled (or, while `hold` is set, keeps it executing until canceled)."""

    def __init__(self, peer: Peer, action_type, name: str):
        super().__init__(peer.node, action_type, name)
        self.peer = peer

    def finish(self, handle):
        result = self.type.Result()
        cmd = handle.request.command
        if self.type is GripperCommand:
            result.position, result.effort = cmd.position + 0.002, cmd.max_effort
        else:
            result.state.name = list(cmd.name)
            result.state.position = [p + 0.002 for p in cmd.position]
            result.state.effort = list(cmd.effort)
        result.stalled, result.reached_goal = True, False
        handle.succeed()
        return result

    def destroy(self):
        self.server.destroy()


@pytest.fixture(scope="module")
def grippers(peer, nodes):
    g = Gripper(peer, GripperCommand, f"{NODE_NS}/gripper_cmd")
    p = Gripper(peer, ParallelGripperCommand, f"{PARALLEL_NS}/gripper_cmd")
    yield g, p
    g.destroy()
    p.destroy()


def grip_client(peer: Peer, ns: str):
    c = peer.node.create_client(Grip, f"{ns}/grasp_orient/grip")
    assert c.wait_for_service(timeout_sec=15.0), f"no {ns}/grasp_orient/grip"
    return c


def grip(peer: Peer, client, grasp_id: str, timeout: float = 15.0):
    return peer.call(client, Grip.Request(grasp_id=grasp_id), timeout=timeout)


def answered(peer: Peer, ns: str, cands: list[dict]) -> dict:
    grasps = GraspClient(peer, ns=ns)
    grasps.wait_matched()
    return grasps.send_and_collect(cands)


def expected_force(recommended: float, limit: float) -> float:
    return min(recommended * FACTOR, limit)


def test_a_gripper_command_server_receives_the_answers_force_times_the_factor_capped(peer, cases, grippers):
    gripper, _ = grippers
    ids = [cases["capped"], cases["free"]]
    got = answered(peer, NODE_NS, [cases["cands"][i] for i in ids])
    client = grip_client(peer, NODE_NS)
    for i in ids:
        answer = got[i]
        assert answer.status == 0, (i, answer.message)
        assert math.isclose(answer.internal_force, cases["solve"][i]["internal_force"], rel_tol=1e-12, abs_tol=0), i
        n = len(gripper.goals)
        r = grip(peer, client, i)
        force = expected_force(answer.internal_force, cases["limit"])
        assert (i == cases["capped"]) == (force < answer.internal_force * FACTOR)
        assert len(gripper.goals) == n + 1, "the server received no goal"
        goal = gripper.goals[-1].command
        assert goal.max_effort == force and goal.position == POSITION, (goal, force)
        assert r.sent and r.force == force and r.recommended_force == answer.internal_force, r
        assert r.action == f"{NODE_NS}/gripper_cmd", r.action
        assert (r.goal_status, r.stalled, r.reached_goal) == (SUCCEEDED, True, False), r
        assert r.position == POSITION + 0.002 and r.effort == force, r
        assert ("capped by max_grip_force" in r.message) == (i == cases["capped"]), r.message


def test_a_member_of_an_answered_set_is_sent(peer, cases, grippers):
    gripper, _ = grippers
    members = [copy.deepcopy(cases["cands"][i]) for i in (cases["free"], cases["capped"])]
    for m in members:
        m["id"] = "set-" + m["id"]
    recommend = peer.node.create_client(Recommend, f"{NODE_NS}/grasp_orient/recommend")
    assert recommend.wait_for_service(timeout_sec=10.0), "no ~/recommend"
    req = Recommend.Request()
    req.candidate_set = pc.fill(GraspCandidateSet(), {"header": {"frame_id": "object"}, "id": "grip-set",
                                                      "candidates": members})
    answer = peer.call(recommend, req, timeout=30.0).recommendation_set
    by_id = {r.candidate_id: r for r in answer.recommendations}
    member = members[0]["id"]
    assert by_id[member].status == 0, by_id[member].message
    r = grip(peer, grip_client(peer, NODE_NS), member)
    force = expected_force(by_id[member].internal_force, cases["limit"])
    assert r.sent and r.force == force and gripper.goals[-1].command.max_effort == force, r


def test_a_parallel_gripper_command_server_gets_every_joint_at_the_force(peer, cases, grippers):
    _, parallel = grippers
    i = cases["over"]  # no max_grip_force on this node: status 0 here
    answer = answered(peer, PARALLEL_NS, [cases["cands"][i]])[i]
    assert answer.status == 0 and answer.internal_force == cases["solve"][i]["internal_force"], answer
    r = grip(peer, grip_client(peer, PARALLEL_NS), i)
    force = answer.internal_force * FACTOR
    cmd = parallel.goals[-1].command
    assert list(cmd.name) == JOINTS and list(cmd.position) == [POSITION] * 2, cmd
    assert list(cmd.effort) == [force, force] and list(cmd.velocity) == [], cmd
    assert r.sent and r.force == force and r.goal_status == SUCCEEDED, r
    assert r.position == POSITION + 0.002 and r.effort == force and r.stalled and not r.reached_goal, r


def test_a_pose_candidates_answer_is_sent(peer, grippers):
    """A pose candidate (a box between the fingers, docs/poses.md): its grip force, equal to solve's on it."""
    _, parallel = grippers
    cand = next(c for c in pc.singles() if c["id"] == "box-mid")
    (want,) = run_solve([cand])
    assert want["recommendation"]["status"] == 0, want
    got: dict = {}
    sub = peer.node.create_subscription(PoseRecommendation, f"{PARALLEL_NS}/pose_recommendations",
                                        lambda m: got.setdefault(m.recommendation.candidate_id, m), reliable_qos(10))
    pub = peer.node.create_publisher(PoseCandidate, f"{PARALLEL_NS}/pose_candidates", reliable_qos(10))
    try:
        assert peer.spin_until(lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0, 15.0)
        pub.publish(pc.fill(PoseCandidate(), cand))
        assert peer.spin_until(lambda: "box-mid" in got, 15.0), "no answer to the pose candidate"
    finally:
        peer.node.destroy_subscription(sub)
        peer.node.destroy_publisher(pub)
    force = got["box-mid"].recommendation.internal_force
    assert math.isclose(force, want["recommendation"]["internal_force"], rel_tol=1e-12, abs_tol=0)
    r = grip(peer, grip_client(peer, PARALLEL_NS), "box-mid")
    assert r.sent and r.recommended_force == force and r.force == force * FACTOR, r
    assert list(parallel.goals[-1].command.effort) == [force * FACTOR] * 2


def test_bad_calls_are_refused_clearly_and_the_node_goes_on(peer, cases, grippers):
    gripper, _ = grippers
    client = grip_client(peer, NODE_NS)
    n = len(gripper.goals)
    r = grip(peer, client, "no-such-grasp")
    assert not r.sent and "no answer with candidate_id \"no-such-grasp\"" in r.message, r
    r = grip(peer, client, "")
    assert not r.sent and "grasp_id is empty" in r.message, r
    bad = copy.deepcopy(cases["cands"][cases["free"]])
    bad["id"], bad["mass"] = "negative-mass", -1.0
    over = cases["over"]
    got = answered(peer, NODE_NS, [bad, cases["cands"][over]])
    assert got["negative-mass"].status == 2 and got[over].status == 3, got
    r = grip(peer, client, "negative-mass")
    assert not r.sent and "has status 2" in r.message and got["negative-mass"].message in r.message, r
    r = grip(peer, client, over)
    assert not r.sent and "has status 3" in r.message, r
    assert r.recommended_force == got[over].internal_force and r.force == 0.0, r
    assert len(gripper.goals) == n, "a refused call sent a goal"

    gripper.reject = True
    try:
        r = grip(peer, client, cases["free"])
    finally:
        gripper.reject = False
    assert not r.sent and "rejected the goal" in r.message and len(gripper.goals) == n + 1, r

    r = grip(peer, client, cases["free"])
    assert r.sent and r.goal_status == SUCCEEDED, r


def test_no_gripper_action_and_no_server_are_clear_failures(peer, cases, nodes):
    i = cases["free"]
    for ns, words in ((NONE_NS, "no gripper action: set gripper_action or parallel_gripper_action"),
                      (ABSENT_NS, f"no action server at {ABSENT_NS}/nobody_home")):
        answer = answered(peer, ns, [cases["cands"][i]])[i]
        r = grip(peer, grip_client(peer, ns), i)
        assert not r.sent and words in r.message, (ns, r)
        assert r.recommended_force == answer.internal_force, r
        # The node goes on: it answers the next candidate.
        again = copy.deepcopy(cases["cands"][i])
        again["id"] = f"after-{ns}"
        assert answered(peer, ns, [again])[again["id"]].status == 0


def test_a_goal_without_result_is_canceled_and_the_node_answers_meanwhile(peer, cases, grippers):
    gripper, _ = grippers
    client = grip_client(peer, NODE_NS)
    grasps = GraspClient(peer, ns=NODE_NS)
    grasps.wait_matched()
    gripper.hold = True
    try:
        n = len(gripper.goals)
        fut = client.call_async(Grip.Request(grasp_id=cases["free"]))
        assert peer.spin_until(lambda: len(gripper.goals) > n and gripper.released is not None, 10.0), \
            "the goal did not reach the server"
        # The goal runs; the node's thread answers a candidate meanwhile.
        probe = copy.deepcopy(cases["cands"][cases["capped"]])
        probe["id"] = "while-gripping"
        answer = grasps.send_one(probe, timeout=GRIP_TIMEOUT / 2)
        assert answer.status == 0 and not fut.done(), "the node's answers waited for the gripper"
        assert peer.spin_until(fut.done, GRIP_TIMEOUT + 10.0), "no response to ~/grip"
    finally:
        gripper.hold = False
    r = fut.result()
    assert r.sent and r.goal_status == 0 and "no result came within grip_timeout" in r.message, r
    assert "the goal was canceled" in r.message and gripper.cancels >= 1, r
    gripper.released = None
    r = grip(peer, client, cases["free"])
    assert r.sent and r.goal_status == SUCCEEDED, r
