"""Gravity and object poses from TF (docs/node.md#tf), from a real rclpy peer over Fast DDS.

The peer publishes transforms as tf2_ros's broadcasters do: a `StaticTransformBroadcaster` keeps every static
transform it was given and publishes them all in one tf2_msgs/TFMessage on /tf_static (reliable,
transient-local, keep-last 1: tf2_ros's StaticBroadcasterQoS), a `TransformBroadcaster` publishes on /tf
(reliable, volatile, keep-last 100: DynamicBroadcasterQoS). tf2_msgs is built by tests/peer/setup.sh from its
Jazzy definition.

The node runs with `gravity_frame:=world`. Random frame trees hang below `world`, one per case, each with one
moving transform sampled at two stamps; every candidate's answer must equal `grasp_orient solve`'s on the same
candidate with its gravity, and a pose candidate's object pose, turned into the candidate's frame by the
numpy computation of tests/ros/tf_cases.py (homogeneous matrices composed along the tree, translation interpolated linearly and
rotation by slerp between the two samples), which shares nothing with the node's TF code. Bad frames (unknown,
a stamp past the latest sample, a tree not joined to `world`) are refused with status 2 naming both frames in
tf2's words, and the candidates after them are answered meanwhile.
"""
from __future__ import annotations

import copy
import json
import math
import random
import subprocess
import time

import numpy as np
import pytest

from conftest import (
    LINE_PREFIX, GraspClient, Peer, binary_path, candidate_msg, random_grasp, reliable_qos, run_solve, to_plain,
)
import pose_cases as pc
from tf_cases import (
    GRAVITY, NS, T1, T2, Tree, homogeneous, matrix, matrix_of, pose_of, random_quaternion, stamp_of,
    tool_pose_by_numpy, tool_pose_gap, transform_msg, vec,
)

from geometry_msgs.msg import TransformStamped  # noqa: E402
from grasp_orient.msg import (  # noqa: E402
    GraspCandidateSet, PoseCandidate, PoseCandidateSet, PoseRecommendation, PoseRecommendationSet,
)
from grasp_orient.srv import Recommend  # noqa: E402
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

TF_TIMEOUT = 0.5
# The namespace of the module's node: its topics and services are NODE_NS/grasp_candidates, NODE_NS/grasp_orient/recommend...
NODE_NS = "/tf_case"
TREES = 220
BOX = {"type": 1, "dimensions": [0.04, 0.06, 0.08]}


class Broadcasters:
    """tf2_ros's StaticTransformBroadcaster and TransformBroadcaster, their QoS and what they publish."""

    def __init__(self, peer: Peer):
        static_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
        dynamic_qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                                 history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
        self.peer = peer
        self.static_pub = peer.node.create_publisher(TFMessage, "/tf_static", static_qos)
        self.dynamic_pub = peer.node.create_publisher(TFMessage, "/tf", dynamic_qos)
        self.statics: dict[str, TransformStamped] = {}

    def send_static(self, transforms: list[TransformStamped]):
        # As StaticTransformBroadcaster::sendTransform: kept by child frame, all of them published again.
        for t in transforms:
            self.statics[t.child_frame_id] = t
        self.static_pub.publish(TFMessage(transforms=list(self.statics.values())))

    def send(self, transforms: list[TransformStamped]):
        self.dynamic_pub.publish(TFMessage(transforms=transforms))

    def wait_matched(self):
        ok = self.peer.spin_until(lambda: self.static_pub.get_subscription_count() > 0
                                  and self.dynamic_pub.get_subscription_count() > 0, 15.0)
        assert ok, "the node did not subscribe /tf and /tf_static"


def publish_trees(tf: Broadcasters, trees: list[Tree]):
    tf.send_static([transform_msg(tr.parent[f], f, 0, *tr.static[f]) for tr in trees for f in tr.static])
    for stamp_index in (0, 1):
        tf.send([transform_msg(tr.parent[tr.moving], tr.moving, *tr.samples[stamp_index]) for tr in trees])


class Gaps:
    """The largest relative difference seen between a number of the node's answers and solve's."""

    def __init__(self):
        self.worst, self.where, self.numbers = 0.0, "", 0

    def note(self, gap: float, where: str):
        self.numbers += 1
        if gap > self.worst:
            self.worst, self.where = gap, where


def close(ros, ref, path: str = "", gaps: Gaps | None = None) -> list[str]:
    """Differences between an answer (to_plain form) and solve's, field by field: numbers within 1e-9 of
    max(1, |a|, |b|) (replay's tolerance; the gravity and poses here come from numpy, not from the node's own
    arithmetic, so they differ from the node's in the last bits, and a force that is zero comes out as 1e-15
    or 2e-15), everything else equal; solve's `line N: ` left out of a message. `gaps` keeps the largest
    relative difference."""
    if isinstance(ref, dict):
        if not isinstance(ros, dict) or set(ros) != set(ref):
            return [f"{path}: keys {sorted(ros) if isinstance(ros, dict) else ros!r} vs solve {sorted(ref)}"]
        return [d for k in sorted(ref) for d in close(ros[k], ref[k], f"{path}{k}.", gaps)]
    p = path.rstrip(".")
    if isinstance(ref, list):
        if not isinstance(ros, list) or len(ros) != len(ref):
            return [f"{p}: {ros!r} vs solve {ref!r}"]
        return [d for i, (a, b) in enumerate(zip(ros, ref)) for d in close(a, b, f"{p}[{i}].", gaps)]
    if isinstance(ref, str) and p.endswith("message"):
        ref = LINE_PREFIX.sub("", ref)
    if isinstance(ref, float) or isinstance(ros, float):
        if isinstance(ref, (int, float)) and isinstance(ros, (int, float)) and not isinstance(ref, bool):
            gap = abs(ros - ref) / max(1.0, abs(ros), abs(ref))
            if gaps is not None:
                gaps.note(gap, p)
            if gap <= 1e-9:
                return []
    return [] if ros == ref else [f"{p}: {ros!r} vs solve {ref!r}"]


def without_tool_poses(answer: dict) -> dict:
    """A pose answer (or a pose set's) without its tool poses: `solve` and `rank` give them in the header frame,
    the node with gravity_frame in world; they are checked apart (check_tool_pose)."""
    if "recommendations" in answer:
        return {**answer, "recommendations": [without_tool_poses(r) for r in answer["recommendations"]]}
    return {k: v for k, v in answer.items() if k != "tool_pose"}


def check_tool_pose(ours: dict, grasp_pose: dict, header: dict, header_in_world: np.ndarray) -> bool:
    """The node's tool pose, with gravity_frame world, is numpy's tool pose in the header frame
    (tool_pose_by_numpy, from the node's own axis, angle and contacts) carried into world by T_world_header at the
    candidate's stamp, within 1e-9, its header world at the candidate's stamp; an answer without a rotation keeps
    the candidate's header and NaN. True when the pose was turned."""
    tp = ours["tool_pose"]
    rid = ours["recommendation"]["candidate_id"]
    if ours["recommendation"]["rotation"]["w"] is None:
        assert tp["header"] == header, (rid, tp["header"], header)
        assert all(v is None for v in [*tp["pose"]["position"].values(), *tp["pose"]["orientation"].values()]), tp
        return False
    assert tp["header"] == {**header, "frame_id": "world"}, (rid, tp["header"], header)
    want = header_in_world @ tool_pose_by_numpy(grasp_pose, ours)
    gap = tool_pose_gap(tp["pose"], want)
    assert gap <= 1e-9, (rid, gap, tp["pose"])
    return True


def wait_known(client: "GraspClient", rng: random.Random, frame: str):
    """Until a candidate in `frame` is answered without a TF refusal: the node has the trees (the static
    transforms reach a node's reader once discovery has matched it, which takes its time on a loaded host)."""
    deadline = time.monotonic() + 20.0
    k = 0
    while time.monotonic() < deadline:
        k += 1
        a = client.send_one(random_grasp(rng, f"known-{frame}-{k}", frame, (T2 // NS, 0)), timeout=10.0)
        if "no transform" not in a.message:
            return
    raise AssertionError(f"the node never had the frame {frame}: {a.message}")


# ------------------------------------------------------------------------------------------------------------
# The peer's endpoints
# ------------------------------------------------------------------------------------------------------------
class PoseClient:
    def __init__(self, peer: Peer):
        self.peer = peer
        self.pub = peer.node.create_publisher(PoseCandidate, f"{NODE_NS}/pose_candidates", reliable_qos(100))
        self.answers: dict[str, object] = {}
        self.order: list[str] = []
        self.sub = peer.node.create_subscription(PoseRecommendation, f"{NODE_NS}/pose_recommendations", self._on,
                                                 reliable_qos(1000))

    def _on(self, m):
        self.answers.setdefault(m.recommendation.candidate_id, m)
        self.order.append(m.recommendation.candidate_id)

    def wait_matched(self):
        ok = self.peer.spin_until(lambda: self.pub.get_subscription_count() > 0
                                  and self.sub.get_publisher_count() > 0, 15.0)
        assert ok, "no match on the pose topics"

    def send(self, cands: list[dict], window: int = 40, timeout: float = 60.0) -> dict[str, dict]:
        ids = [c["id"] for c in cands]
        deadline = time.monotonic() + timeout
        i = 0
        while (i < len(cands) or any(x not in self.answers for x in ids)) and time.monotonic() < deadline:
            while i < len(cands) and sum(1 for x in ids[:i] if x not in self.answers) < window:
                self.pub.publish(pc.fill(PoseCandidate(), cands[i]))
                i += 1
            self.peer.executor.spin_once(timeout_sec=0.05)
        missing = [x for x in ids if x not in self.answers]
        assert not missing, f"{len(missing)} pose candidates not answered: {missing[:5]}"
        return {x: to_plain(self.answers[x]) for x in ids}


@pytest.fixture(scope="module")
def tf_node(start_node):
    """A node of its own, in a namespace of its own (the session's default node, started by an earlier file,
    would answer these candidates too, from their own gravity), stopped at the module's end."""
    n = start_node("--ros-args", "-r", f"__ns:={NODE_NS}", "-p", "gravity_frame:=world", "-p", f"tf_timeout:={TF_TIMEOUT}",
                   "-p", "record:=false", name="grasp_orient node (gravity_frame world)")
    yield n
    n.stop_and_check()


@pytest.fixture(scope="module")
def clients(peer, tf_node):
    tf = Broadcasters(peer)
    grasps = GraspClient(peer, ns=NODE_NS)
    poses = PoseClient(peer)
    tf.wait_matched()
    grasps.wait_matched()
    poses.wait_matched()
    return tf, grasps, poses


# ------------------------------------------------------------------------------------------------------------
# The cases
# ------------------------------------------------------------------------------------------------------------
def random_stamp(rng: random.Random) -> int:
    """Between the two samples (interpolated), or 0 (the latest) one time in five."""
    return 0 if rng.random() < 0.2 else rng.randrange(T1 + 1, T2)


def cases(rng: random.Random, trees: list[Tree]):
    """Per tree: a planar grasp candidate in one of its frames, and a pose candidate whose object is given in
    another; each with the JSON `solve` answers alike, gravity and object pose turned by numpy."""
    grasps, grasp_refs, poses, pose_refs = [], [], [], []
    for k, tr in enumerate(trees):
        frame = rng.choice(tr.frames[1:])
        stamp = random_stamp(rng)
        c = random_grasp(rng, f"grasp-{k}", frame, (stamp // NS, stamp % NS))
        ref = copy.deepcopy(c)
        # g in the candidate's frame c: R_world_c^T g_world (a direction: the translation drops out).
        ref["gravity"] = vec(tr.in_world(frame, stamp)[:3, :3].T @ GRAVITY)
        grasps.append(c)
        grasp_refs.append(ref)

        frame = rng.choice(tr.frames[1:])
        object_frame = rng.choice([f for f in tr.frames if f != frame])
        stamp = random_stamp(rng)
        header_in_world = tr.in_world(frame, stamp)
        # The object somewhere near the candidate's origin, turned at random, given in object_frame; the
        # gripper at its centre, closing along its y (0.06 m across, the opening 0.09 m).
        obj_in_header = homogeneous([rng.uniform(-0.3, 0.3) for _ in range(3)], random_quaternion(rng))
        obj_in_its_frame = np.linalg.inv(tr.in_world(object_frame, stamp)) @ header_in_world @ obj_in_header
        p = {"header": {"frame_id": frame, "stamp": stamp_of(stamp)}, "id": f"pose-{k}",
             "grasp_pose": pose_of(obj_in_header), "width": 0.09,
             "object": {"pose": pose_of(obj_in_its_frame), "frame_id": object_frame, "primitive": BOX,
                        "scale": {"x": 1.0, "y": 1.0, "z": 1.0}, "mass": rng.uniform(0.1, 2.0),
                        "friction": rng.uniform(0.3, 1.0)},
             "gravity": {"x": 0.0, "y": 0.0, "z": -1.0}}
        ref = copy.deepcopy(p)
        # T_header_object = T_world_header^-1 T_world_objectframe T_objectframe_object, from the message's pose.
        turned = np.linalg.inv(header_in_world) @ tr.in_world(object_frame, stamp) @ matrix_of(p["object"]["pose"])
        ref["object"]["pose"] = pose_of(turned)
        del ref["object"]["frame_id"]
        ref["gravity"] = vec(header_in_world[:3, :3].T @ GRAVITY)
        poses.append(p)
        pose_refs.append(ref)
    return grasps, grasp_refs, poses, pose_refs


def test_answers_equal_solve_with_gravity_and_poses_turned_by_numpy(clients):
    tf, grasp_client, pose_client = clients
    rng = random.Random(20261207)
    trees = [Tree(rng, k) for k in range(TREES)]
    publish_trees(tf, trees)
    wait_known(grasp_client, random.Random(1), trees[-1].moving)
    grasps, grasp_refs, poses, pose_refs = cases(rng, trees)

    def interpolated(tree: Tree, frame: str, stamp: dict) -> bool:
        t = stamp["sec"] * NS + stamp["nanosec"]
        return tree.crosses_moving(frame) and T1 < t < T2

    # Enough of them turned by the moving transform between its two samples (slerp, not a sample).
    moving = sum(interpolated(tr, c["header"]["frame_id"], c["header"]["stamp"]) for tr, c in zip(trees, grasps))
    moving_poses = sum(interpolated(tr, c["header"]["frame_id"], c["header"]["stamp"])
                       or interpolated(tr, c["object"]["frame_id"], c["header"]["stamp"])
                       for tr, c in zip(trees, poses))
    assert moving >= 40 and moving_poses >= 40, (moving, moving_poses)
    gaps = Gaps()
    got = grasp_client.send_and_collect(grasps, timeout=120.0, window=40)
    want = run_solve(grasp_refs)
    statuses = []
    for c, ref in zip(grasps, want):
        ours = to_plain(got[c["id"]])
        diffs = close(ours, ref, gaps=gaps)
        assert not diffs, f"{c['id']} in {c['header']['frame_id']}: {ours['message']!r} {diffs[:5]}"
        statuses.append(ours["status"])
    assert statuses.count(2) < len(statuses) // 10, statuses  # not refused: answered
    got = pose_client.send(poses)
    want = run_solve(pose_refs)
    statuses = []
    turned = 0
    for tr, c, ref in zip(trees, poses, want):
        ours = got[c["id"]]
        diffs = close(without_tool_poses(ours), without_tool_poses(ref), gaps=gaps)
        assert not diffs, f"{c['id']}: {ours['recommendation']['message']!r} {diffs[:5]}"
        statuses.append(ours["recommendation"]["status"])
        stamp = c["header"]["stamp"]["sec"] * NS + c["header"]["stamp"]["nanosec"]
        turned += check_tool_pose(ours, c["grasp_pose"], c["header"], tr.in_world(c["header"]["frame_id"], stamp))
    assert statuses.count(2) < len(statuses) // 10, statuses
    assert turned >= TREES // 2, f"{turned} tool poses turned into world"
    print(f"{len(trees)} frame trees: {len(grasps)} candidates ({moving} turned between two samples of the moving "
          f"transform) and {len(poses)} pose candidates ({moving_poses}); {gaps.numbers} numbers compared, the "
          f"largest relative difference {gaps.worst:.3g} ({gaps.where})")


def test_bad_frames_are_refused_in_tf2s_words_and_the_next_is_answered(clients, tf_node):
    tf, grasp_client, pose_client = clients
    rng = random.Random(7)
    tree = Tree(rng, 9000)
    publish_trees(tf, [tree])
    # A tree of its own, not joined to world.
    tf.send_static([transform_msg("island", "island_f0", 0, [0, 0, 1], [0, 0, 0, 1])])
    wait_known(grasp_client, random.Random(2), tree.moving)
    wait_known(grasp_client, random.Random(2), tree.frames[-1])
    moving = tree.moving
    good = tree.frames[-1]

    def grasp(cid, frame, stamp):
        return random_grasp(random.Random(cid), cid, frame, (stamp // NS, stamp % NS))

    past = T2 + 5 * NS
    before = T1 - 5 * NS
    bad = [
        (grasp("bad-unknown", "no_such_frame", T1 + NS),
         'invalid input: no transform of the gravity from frame "world" to frame "no_such_frame": "no_such_frame" '
         'passed to lookupTransform argument target_frame does not exist.  (waited tf_timeout 0.5 s)'),
        (grasp("bad-future", moving, past),
         f'invalid input: no transform of the gravity from frame "world" to frame "{moving}": Lookup would require '
         'extrapolation into the future.  Requested time 1007.000000 but the latest data is at time '
         f'1002.000000, when looking up transform from frame [world] to frame [{moving}] (waited tf_timeout 0.5 s)'),
        (grasp("bad-past", moving, before),
         f'invalid input: no transform of the gravity from frame "world" to frame "{moving}": Lookup would require '
         'extrapolation into the past.  Requested time 995.000000 but the earliest data is at time '
         f'1000.000000, when looking up transform from frame [world] to frame [{moving}] (waited tf_timeout 0.5 s)'),
        (grasp("bad-island", "island_f0", T1 + NS),
         'invalid input: no transform of the gravity from frame "world" to frame "island_f0": Could not find a '
         "connection between 'island_f0' and 'world' because they are not part of the same tree.Tf has two or "
         'more unconnected trees. (waited tf_timeout 0.5 s)'),
    ]
    for cand, message in bad:
        next_one = grasp(f"after-{cand['id']}", good, T1 + NS)
        n = len(grasp_client.order)
        t0 = time.monotonic()
        grasp_client.pub.publish(candidate_msg(cand))
        grasp_client.pub.publish(candidate_msg(next_one))
        ok = grasp_client.peer.spin_until(lambda: cand["id"] in grasp_client.answers, 10.0)
        waited = time.monotonic() - t0
        assert ok, f"no answer to {cand['id']}:\n{tf_node.output()}"
        order = [a.candidate_id for a in grasp_client.order[n:]]
        # The next candidate was answered while the bad one waited for its transform.
        assert order[:2] == [next_one["id"], cand["id"]], order
        assert grasp_client.answers[next_one["id"]][0].status != 2, grasp_client.answers[next_one["id"]][0].message
        a = grasp_client.answers[cand["id"]][0]
        assert (a.status, a.message) == (2, message), (a.status, a.message)
        assert waited >= TF_TIMEOUT * 0.9, waited
    # An object given in an unknown frame: the pose's transform is named.
    p = {"header": {"frame_id": good, "stamp": stamp_of(T1 + NS)}, "id": "bad-object-frame",
         "grasp_pose": pc.pose(0, 0, 0), "width": 0.09,
         "object": {"pose": pc.pose(0, 0, 0), "frame_id": "shelf", "primitive": BOX,
                    "scale": {"x": 1.0, "y": 1.0, "z": 1.0}, "mass": 0.5, "friction": 0.5},
         "gravity": {"x": 0.0, "y": 0.0, "z": -1.0}}
    got = pose_client.send([p])["bad-object-frame"]["recommendation"]
    assert got["status"] == 2 and got["message"].startswith(
        f'invalid input: no transform of the pose from frame "shelf" to frame "{good}": "shelf" passed to '
        'lookupTransform argument source_frame does not exist.'), got["message"]


def test_a_candidate_waits_for_a_transform_that_comes_later(clients):
    tf, grasp_client, _ = clients
    cand = random_grasp(random.Random(3), "late", "late_frame", (T1 // NS, 0))
    n = len(grasp_client.order)
    grasp_client.pub.publish(candidate_msg(cand))
    grasp_client.peer.spin_for(0.15)
    assert len(grasp_client.order) == n, "answered before its transform came"
    # Tilted by 1.1 rad about (1, 1, 0)/sqrt(2): gravity keeps a part in the planar candidate's x-y plane, so the
    # answer is a real one (a turn by 180 deg about x would leave it only +z, which the planar model refuses).
    half = 0.55
    s = math.sin(half) / math.sqrt(2.0)
    q = [s, s, 0.0, math.cos(half)]
    tf.send_static([transform_msg("world", "late_frame", 0, [0.3, -0.2, 0.1], q)])
    ok = grasp_client.peer.spin_until(lambda: "late" in grasp_client.answers, 5.0)
    assert ok, "not answered once its transform came"
    ref = copy.deepcopy(cand)
    # g in the frame: R_world_frame^T g_world.
    ref["gravity"] = vec(matrix(q).T @ GRAVITY)
    assert math.hypot(ref["gravity"]["x"], ref["gravity"]["y"]) > 5.0, ref["gravity"]
    got = to_plain(grasp_client.answers["late"][0])
    assert got["status"] in (0, 3), (got["status"], got["message"])
    diffs = close(got, run_solve([ref])[0])
    assert not diffs, diffs


def rank_json(lines: list[dict]) -> dict:
    """`grasp_orient rank --json` of these lines: candidates taken as one set, or one pose set."""
    r = subprocess.run([str(binary_path()), "rank", "--json"], input="".join(json.dumps(x) + "\n" for x in lines),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode in (0, 1), f"rank exited {r.returncode}: {r.stderr[-2000:]}"
    return json.loads(r.stdout)


def assert_ranked_alike(got: dict, want: dict):
    """The same members ranked, in an order whose ranked-by values agree with rank's within 1e-9 (members
    that tie, as grasps of a box across the same faces do, may come in either order: their values differ
    only in the last bits between the node's TF and numpy)."""
    assert got["ranking"] and sorted(got["ranking"]) == sorted(want["ranking"]), (got["ranking"], want["ranking"])

    def values(a: dict) -> list[float]:
        rec = a["recommendations"]
        return [(rec[i].get("recommendation", rec[i]))[a["ranked_by"]] for i in a["ranking"]]

    for x, y in zip(values(got), values(want)):
        assert abs(x - y) <= 1e-9 * max(1.0, abs(x), abs(y)), (values(got), values(want))


def test_sets_are_turned_member_by_member_and_refused_whole(clients, peer):
    """A candidate set through ~/recommend, its members in frames of several trees at their own stamps, equals
    `rank` on the members with their gravity turned by numpy; a pose set on its topic, its object in another
    frame, equals `rank` on the set turned by numpy; a set with one member in an unknown frame is refused whole,
    naming both frames."""
    tf, grasp_client, _ = clients
    rng = random.Random(99)
    trees = [Tree(rng, 6000 + k) for k in range(8)]
    publish_trees(tf, trees)
    wait_known(grasp_client, random.Random(4), trees[-1].moving)
    members, refs = [], []
    for k in range(24):
        tr = trees[k % len(trees)]
        frame, stamp = rng.choice(tr.frames[1:]), random_stamp(rng)
        c = random_grasp(rng, f"member-{k}", frame, (stamp // NS, stamp % NS))
        ref = copy.deepcopy(c)
        ref["gravity"] = vec(tr.in_world(frame, stamp)[:3, :3].T @ GRAVITY)
        members.append(c)
        refs.append(ref)
    recommend = peer.node.create_client(Recommend, f"{NODE_NS}/grasp_orient/recommend")
    assert recommend.wait_for_service(timeout_sec=10.0), "no ~/recommend"

    def call(cset: dict) -> dict:
        req = Recommend.Request()
        req.candidate_set = pc.fill(GraspCandidateSet(), cset)
        return to_plain(peer.call(recommend, req, timeout=30.0).recommendation_set)

    got = call({"header": {"frame_id": "world", "stamp": stamp_of(0)}, "id": "tf-set", "candidates": members})
    want = rank_json(refs)
    for field in ("status", "message", "recommendations", "ranked_by"):
        diffs = close(got[field], want[field], field)
        assert not diffs, diffs[:5]
    assert_ranked_alike(got, want)

    bad = copy.deepcopy(members[:3])
    bad[1]["header"]["frame_id"] = "no_such_frame"
    got = call({"header": {"frame_id": "world", "stamp": stamp_of(0)}, "id": "tf-set-bad", "candidates": bad})
    assert (got["status"], got["recommendations"]) == (2, []), got
    assert got["message"].startswith('invalid input: no transform of the gravity from frame "world" to frame '
                                     '"no_such_frame": '), got["message"]

    # A pose set: its header in one frame of a tree, its object given in another.
    tr = trees[0]
    frame, object_frame = tr.frames[-1], tr.frames[1]
    stamp = (T1 + T2) // 2 + 123
    header_in_world = tr.in_world(frame, stamp)
    obj_in_header = homogeneous([0.1, -0.2, 0.3], random_quaternion(rng))
    obj_in_its_frame = np.linalg.inv(tr.in_world(object_frame, stamp)) @ header_in_world @ obj_in_header
    poses = []
    for k, (dx, turn) in enumerate([(0.0, 0.0), (0.005, 0.0), (0.0, math.pi / 2), (0.01, 0.3)]):
        along_z = homogeneous([dx, 0.0, 0.0], [0.0, 0.0, math.sin(turn / 2), math.cos(turn / 2)])
        poses.append({"id": f"p{k}", "grasp_pose": pose_of(obj_in_header @ along_z), "width": 0.09})
    pset = {"header": {"frame_id": frame, "stamp": stamp_of(stamp)}, "id": "tf-pose-set",
            "object": {"pose": pose_of(obj_in_its_frame), "frame_id": object_frame, "primitive": BOX,
                       "scale": {"x": 1.0, "y": 1.0, "z": 1.0}, "mass": 0.4, "friction": 0.6},
            "poses": poses, "gravity": {"x": 0.0, "y": 0.0, "z": -1.0}}
    ref = copy.deepcopy(pset)
    ref["object"]["pose"] = pose_of(np.linalg.inv(header_in_world) @ tr.in_world(object_frame, stamp)
                                    @ matrix_of(pset["object"]["pose"]))
    del ref["object"]["frame_id"]
    ref["gravity"] = vec(header_in_world[:3, :3].T @ GRAVITY)
    answers: dict[str, object] = {}
    pub = peer.node.create_publisher(PoseCandidateSet, f"{NODE_NS}/pose_candidate_sets", reliable_qos(10))
    sub = peer.node.create_subscription(PoseRecommendationSet, f"{NODE_NS}/pose_recommendation_sets",
                                        lambda m: answers.setdefault(m.set_id, m), reliable_qos(10))
    try:
        assert peer.spin_until(lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0, 15.0)
        pub.publish(pc.fill(PoseCandidateSet(), pset))
        assert peer.spin_until(lambda: "tf-pose-set" in answers, 30.0), "no answer to the pose set"
        got = to_plain(answers["tf-pose-set"])
        want = rank_json([ref])
        diffs = close({**without_tool_poses(got), "ranking": []}, {**without_tool_poses(want), "ranking": []})
        assert not diffs, diffs[:5]
        assert_ranked_alike(got, want)
        turned = sum(check_tool_pose(r, p["grasp_pose"], pset["header"], header_in_world)
                     for p, r in zip(poses, got["recommendations"]))
        assert turned >= 3, turned
    finally:
        peer.node.destroy_publisher(pub)
        peer.node.destroy_subscription(sub)
