"""MoveIt's grasps and objects (docs/node.md#moveit), from a real rclpy peer over Fast DDS.

moveit_msgs, octomap_msgs and object_recognition_msgs are built by tests/peer/setup.sh from their Jazzy
definitions; shape_msgs and trajectory_msgs are their Jazzy wheels. The node runs in a namespace of its own with
`gravity_frame:=world` and an `objects_file` giving the objects' mass and friction by id. The peer publishes a
static frame tree as tf2_ros's StaticTransformBroadcaster does (world -> base -> camera, world -> table, each
turned and moved arbitrarily), CollisionObjects on /collision_object and inside /planning_scene diffs (ADD, MOVE,
REMOVE, an inline mesh), and calls ~/rank_grasps with grasps in the camera frame. Every answer must equal, field
for field, `grasp_orient solve` on the equivalent PoseCandidate: the grasp pose in the camera frame, the object's
pose (its CollisionObject pose, then its shape's) and gravity carried into the camera frame by homogeneous
matrices composed in numpy here, which shares nothing with the node's TF or its scene code. The response's grasps
must be the ranked ones in order, with max_contact_force the grip force, grasp_quality the least grip force over
their own and every posture point's effort the grip force. Bad inputs (an unknown id, a removed object, an object
with no mass, grasps in a frame not joined to world or in two frames) are each refused with status 2 and the
node answers the next call.
"""
from __future__ import annotations

import copy
import math
import random
import subprocess

import numpy as np
import pytest

from conftest import binary_path, reliable_qos, run_solve, to_plain
import pose_cases as pc
from tf_cases import GRAVITY, homogeneous, matrix_of, pose_of, random_quaternion, transform_msg, vec
from test_tf import check_tool_pose, close, without_tool_poses

from moveit_msgs.msg import CollisionObject, Grasp, PlanningScene  # noqa: E402
from grasp_orient.msg import PoseCandidateSet, PoseRecommendationSet  # noqa: E402
from grasp_orient.srv import RankGrasps, RecommendPoses  # noqa: E402
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

NODE_NS = "/moveit_case"
# CollisionObject's operations: rclpy takes a `byte` field as bytes (an int there is serialized as garbage).
ADD, REMOVE, APPEND, MOVE = bytes([0]), bytes([1]), bytes([2]), bytes([3])
BOX = [0.04, 0.06, 0.08]
MASS, FRICTION, DENSITY = 0.4, 0.6, 500.0
TABLE = f"""objects:
  box: {{mass: {MASS}, friction: {FRICTION}}}
  meshbox: {{density: {DENSITY}, friction: 0.5, center_of_mass: [0.001, -0.002, 0.003]}}
  nomass_neighbour: {{mass: 1.0, friction: 1.0}}
meshes:
  "{pc.BLOCK_RESOURCE}": {{mass: 0.35, friction: 0.45, center_of_mass: [0.002, 0.001, -0.003]}}
"""


def rand_transform(rng: random.Random) -> tuple[list[float], list[float]]:
    return [rng.uniform(-1.0, 1.0) for _ in range(3)], random_quaternion(rng)


class World:
    """The frame tree, as numpy matrices: each frame in world."""

    def __init__(self, rng: random.Random, suffix: str = ""):
        self.suffix = suffix
        self.edges = {f"base{suffix}": ("world", *rand_transform(rng)),
                      f"camera{suffix}": (f"base{suffix}", *rand_transform(rng)),
                      f"table{suffix}": ("world", *rand_transform(rng))}

    def in_world(self, frame: str) -> np.ndarray:
        if frame == "world":
            return np.eye(4)
        parent, t, q = self.edges[frame]
        return self.in_world(parent) @ homogeneous(t, q)

    def a_in_b(self, a: str, b: str) -> np.ndarray:
        """Frame `a` in frame `b`, both named without the tree's suffix."""
        name = (lambda f: f if f == "world" else f + self.suffix)
        return np.linalg.inv(self.in_world(name(b))) @ self.in_world(name(a))

    def frame(self, f: str) -> str:
        return f + self.suffix

    def messages(self):
        return [transform_msg(parent, child, 0, t, q) for child, (parent, t, q) in self.edges.items()]


@pytest.fixture(scope="module")
def moveit_node(start_node, tmp_path_factory):
    """A node of its own in its own namespace, with gravity_frame world and the objects table, stopped at the
    module's end (the suite shares one pytest session)."""
    objects = tmp_path_factory.mktemp("moveit") / "objects.yaml"
    objects.write_text(TABLE)
    n = start_node("--ros-args", "-r", f"__ns:={NODE_NS}", "-p", "gravity_frame:=world", "-p", "tf_timeout:=0.5",
                   "-p", f"objects_file:={objects}", "-p", "record:=false", name="grasp_orient node (MoveIt)")
    yield n
    if n.proc.poll() is None:
        n.stop_and_check()


class MoveIt:
    """The peer's endpoints: the static broadcaster, /collision_object, /planning_scene and ~/rank_grasps."""

    def __init__(self, peer, world: World):
        static_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.peer, self.world = peer, world
        self.tf = peer.node.create_publisher(TFMessage, "/tf_static", static_qos)
        self.objects = peer.node.create_publisher(CollisionObject, "/collision_object", reliable_qos(100))
        self.scenes = peer.node.create_publisher(PlanningScene, "/planning_scene", reliable_qos(100))
        self.rank = peer.node.create_client(RankGrasps, f"{NODE_NS}/grasp_orient/rank_grasps")
        ok = peer.spin_until(lambda: all(p.get_subscription_count() > 0 for p in (self.tf, self.objects, self.scenes)),
                             15.0)
        assert ok, "the node did not subscribe /tf_static, /collision_object and /planning_scene"
        assert self.rank.wait_for_service(timeout_sec=15.0), "no ~/rank_grasps"
        self.tf.publish(TFMessage(transforms=world.messages()))

    def call(self, obj: dict, grasps: list[dict], width: float = 0.09, limit: float = 0.0) -> dict:
        req = RankGrasps.Request()
        pc.fill(req.object, obj)
        req.grasps = [pc.fill(Grasp(), g) for g in grasps]
        req.width, req.max_grip_force = width, limit
        return to_plain(self.peer.call(self.rank, req, timeout=30.0))

    def until(self, obj: dict, grasps: list[dict], done, send=None) -> dict:
        """Calls until `done(answer)`, `send()` before each call: the node has heard the object by then (a
        volatile sample sent before the node's reader has matched the peer's writer is lost, so it is sent
        again; each operation sent twice is the same as sent once)."""
        for _ in range(100):
            if send is not None:
                send()
                self.peer.spin_for(0.05)
            a = self.call(obj, grasps)
            if done(a):
                return a
            self.peer.spin_for(0.1)
        raise AssertionError(f"never: {a['recommendation_set']['message']}")


@pytest.fixture(scope="module")
def moveit(peer, moveit_node):
    return MoveIt(peer, World(random.Random(39)))


def test_the_node_offers_rank_grasps_and_listens_to_moveit(moveit, peer):
    """The service and the two subscriptions in the ROS graph, with their types; the subscriptions reliable and
    volatile, as move_group's publishers offer."""
    assert peer.spin_until(lambda: ("grasp_orient", NODE_NS) in peer.node.get_node_names_and_namespaces(), 15.0)
    services = dict(peer.node.get_service_names_and_types_by_node("grasp_orient", NODE_NS))
    assert "grasp_orient/srv/RankGrasps" in services.get(f"{NODE_NS}/grasp_orient/rank_grasps", []), services
    for topic, typ in [("/collision_object", "moveit_msgs/msg/CollisionObject"),
                       ("/planning_scene", "moveit_msgs/msg/PlanningScene")]:
        ours = [i for i in peer.node.get_subscriptions_info_by_topic(topic)
                if (i.node_name, i.node_namespace) == ("grasp_orient", NODE_NS)]
        assert ours, f"the node does not subscribe {topic}"
        for i in ours:
            assert i.topic_type == typ, (topic, i.topic_type)
            q = i.qos_profile
            assert (q.reliability, q.durability) == (ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE), (topic, q)


def box_object(oid: str, frame: str, pose: dict, shape_pose: dict, op: int = 0) -> dict:
    return {"header": {"frame_id": frame}, "id": oid, "pose": pose, "operation": bytes([op]),
            "primitives": [{"type": 1, "dimensions": BOX}], "primitive_poses": [shape_pose]}


def grasps_on(shape_in_camera: np.ndarray, n: int, rng: random.Random, camera: str = "camera") -> list[dict]:
    """Grasps in the camera frame closing across the box's y faces, shifted and turned about its z."""
    out = []
    for k in range(n):
        dx, turn = rng.uniform(-0.01, 0.01), rng.uniform(-0.6, 0.6)
        along_z = homogeneous([dx, 0.0, rng.uniform(-0.01, 0.01)], [0.0, 0.0, math.sin(turn / 2), math.cos(turn / 2)])
        out.append({"id": f"g{k}", "grasp_pose": {"header": {"frame_id": camera},
                                                  "pose": pose_of(shape_in_camera @ along_z)},
                    "grasp_posture": {"joint_names": ["left_finger", "right_finger"],
                                      "points": [{"positions": [0.0, 0.0]}]}})
    return out


def expected(world: World, obj_frame: str, shape_in_frame: np.ndarray, shape: dict, grasps: list[dict],
             mass: float, friction: float, com: list[float] | None = None) -> list[dict]:
    """The equivalent PoseCandidates, turned into the camera frame by numpy."""
    frame_in_camera = world.a_in_b(obj_frame, "camera")
    gravity = world.in_world(world.frame("camera"))[:3, :3].T @ GRAVITY
    obj = {"pose": pose_of(frame_in_camera @ shape_in_frame), "scale": {"x": 1.0, "y": 1.0, "z": 1.0},
           "mass": mass, "friction": friction, **shape}
    if com is not None:
        obj.update(has_center_of_mass=True, center_of_mass=vec(com))
    return [{"header": {"frame_id": world.frame("camera"), "stamp": {"sec": 0, "nanosec": 0}}, "id": g["id"],
             "grasp_pose": g["grasp_pose"]["pose"], "width": 0.09, "object": copy.deepcopy(obj), "gravity": vec(gravity)}
            for g in grasps]


def check(moveit: MoveIt, answer: dict, grasps: list[dict], cands: list[dict], world: World | None = None) -> int:
    """The answer equals solve's field for field; the response's grasps are the ranked ones, filled."""
    rs = answer["recommendation_set"]
    assert rs["status"] == 0, rs["message"]
    want = run_solve(cands)
    diffs = close(without_tool_poses(rs)["recommendations"], [without_tool_poses(w) for w in want], "recommendations")
    assert not diffs, diffs[:5]
    world = world or moveit.world
    camera_in_world = world.in_world(world.frame("camera"))
    for g, r in zip(grasps, rs["recommendations"]):
        check_tool_pose(r, g["grasp_pose"]["pose"], rs["header"], camera_in_world)
    forces = [w["recommendation"]["internal_force"] for w in want]
    held = [i for i, w in enumerate(want) if w["recommendation"]["status"] == 0]
    assert sorted(rs["ranking"]) == held, (rs["ranking"], held)
    along = [forces[i] for i in rs["ranking"]]
    assert all(b >= a - 1e-9 * max(1.0, a) for a, b in zip(along, along[1:])), along
    assert answer["indices"] == rs["ranking"]
    least = forces[rs["ranking"][0]] if rs["ranking"] else 0.0
    for i, g in zip(answer["indices"], answer["grasps"]):
        grip = rs["recommendations"][i]["recommendation"]["internal_force"]
        assert g["id"] == grasps[i]["id"]
        assert g["grasp_pose"] == {**grasps[i]["grasp_pose"], "header": {"frame_id": world.frame("camera"),
                                                                          "stamp": {"sec": 0, "nanosec": 0}}}
        assert g["max_contact_force"] == float(np.float32(grip)), (g["max_contact_force"], grip)
        assert abs(g["grasp_quality"] - least / grip) <= 1e-12, (g["grasp_quality"], least, grip)
        assert [p["effort"] for p in g["grasp_posture"]["points"]] == [[grip, grip]]
        assert abs(grip - forces[i]) <= 1e-9 * max(1.0, grip)
    return len(held)


def test_grasps_on_a_collision_object_equal_solve(moveit):
    """A box on /collision_object, in the table frame, its shape turned inside it; grasps in the camera frame;
    the call names only its id."""
    rng = random.Random(1)
    pose, shape_pose = rand_transform(rng), rand_transform(rng)
    obj = box_object("box", "table", pose_of(homogeneous(*pose)), pose_of(homogeneous(*shape_pose)))
    shape_in_table = homogeneous(*pose) @ homogeneous(*shape_pose)
    grasps = grasps_on(moveit.world.a_in_b("table", "camera") @ shape_in_table, 12, rng)
    answer = moveit.until({"id": "box"}, grasps, lambda a: "not known" not in a["recommendation_set"]["message"]
                          and "no transform" not in a["recommendation_set"]["message"],
                          send=lambda: moveit.objects.publish(pc.fill(CollisionObject(), obj)))
    cands = expected(moveit.world, "table", shape_in_table, {"primitive": {"type": 1, "dimensions": BOX}}, grasps,
                     MASS, FRICTION)
    assert check(moveit, answer, grasps, cands) >= 8
    # A gripper limit below some grasps' force: those get status 3 and are left out of the response.
    forces = sorted(r["recommendation"]["internal_force"] for r in answer["recommendation_set"]["recommendations"]
                    if r["recommendation"]["status"] == 0)
    limit = (forces[2] + forces[3]) / 2
    limited = moveit.call({"id": "box"}, grasps, limit=limit)
    statuses = [r["recommendation"]["status"] for r in limited["recommendation_set"]["recommendations"]]
    assert statuses.count(3) >= 1 and len(limited["grasps"]) == 3, (statuses, len(limited["grasps"]))


def test_a_planning_scene_diff_adds_moves_and_removes(moveit):
    """An inline mesh added in a planning-scene diff (its mass from its density and closed volume, its centre
    of mass from the table), then moved by a MOVE diff, given a second shape by an APPEND diff, then removed by a
    REMOVE on /collision_object."""
    rng = random.Random(2)
    mesh = pc.block_mesh()
    for v in mesh["vertices"]:
        v.update(x=v["x"] / 1000, y=v["y"] / 1000, z=v["z"] / 1000)
    pose, mesh_pose = rand_transform(rng), rand_transform(rng)
    obj = {"header": {"frame_id": "base"}, "id": "meshbox", "pose": pose_of(homogeneous(*pose)), "operation": ADD,
           "meshes": [mesh], "mesh_poses": [pose_of(homogeneous(*mesh_pose))]}
    diff = PlanningScene(is_diff=True)
    diff.world.collision_objects = [pc.fill(CollisionObject(), obj)]
    shape_in_base = homogeneous(*pose) @ homogeneous(*mesh_pose)
    grasps = grasps_on(moveit.world.a_in_b("base", "camera") @ shape_in_base, 8, rng)
    answer = moveit.until({"id": "meshbox"}, grasps, lambda a: "not known" not in a["recommendation_set"]["message"],
                          send=lambda: moveit.scenes.publish(diff))
    # The block is 40 x 60 x 80 mm: its volume times the density; the centre of mass given in the object's
    # frame is the mesh's frame's point mesh_pose^-1 c.
    mass = DENSITY * 0.04 * 0.06 * 0.08
    com = (np.linalg.inv(homogeneous(*mesh_pose)) @ np.array([0.001, -0.002, 0.003, 1.0]))[:3]
    shape = {"inline_mesh": mesh}
    assert check(moveit, answer, grasps, expected(moveit.world, "base", shape_in_base, shape, grasps, mass, 0.5,
                                                  list(com))) >= 4
    # MOVE: a new pose in the table frame, shapes untouched.
    new_pose = rand_transform(rng)
    moved = PlanningScene(is_diff=True)
    moved.world.collision_objects = [pc.fill(CollisionObject(), {"header": {"frame_id": "table"}, "id": "meshbox",
                                                                 "pose": pose_of(homogeneous(*new_pose)), "operation": MOVE})]
    shape_in_table = homogeneous(*new_pose) @ homogeneous(*mesh_pose)
    grasps = grasps_on(moveit.world.a_in_b("table", "camera") @ shape_in_table, 8, rng)
    answer = moveit.until({"id": "meshbox"}, grasps, lambda a: a["recommendation_set"]["status"] == 0
                          and sum(r["recommendation"]["status"] == 0
                                  for r in a["recommendation_set"]["recommendations"]) >= 4,
                          send=lambda: moveit.scenes.publish(moved))
    assert check(moveit, answer, grasps, expected(moveit.world, "table", shape_in_table, shape, grasps, mass, 0.5,
                                                  list(com))) >= 4
    # APPEND in a diff: a box joins the mesh, and an object of two shapes is refused, saying so.
    appended = PlanningScene(is_diff=True)
    appended.world.collision_objects = [pc.fill(CollisionObject(), {
        "id": "meshbox", "operation": APPEND, "primitives": [{"type": 1, "dimensions": BOX}],
        "primitive_poses": [pose_of(np.eye(4))]})]
    answer = moveit.until({"id": "meshbox"}, grasps, lambda a: a["recommendation_set"]["status"] == 2,
                          send=lambda: moveit.scenes.publish(appended))
    assert "1 primitives and 1 meshes" in answer["recommendation_set"]["message"], answer["recommendation_set"]
    # REMOVE on /collision_object: the next call naming it is refused, saying so.
    remove = pc.fill(CollisionObject(), {"id": "meshbox", "operation": REMOVE})
    answer = moveit.until({"id": "meshbox"}, grasps, lambda a: a["recommendation_set"]["status"] == 2,
                          send=lambda: moveit.objects.publish(remove))
    assert "\"meshbox\" was removed" in answer["recommendation_set"]["message"], answer["recommendation_set"]
    assert answer["grasps"] == [] and answer["recommendation_set"]["recommendations"] == []


def test_bad_calls_are_refused_and_the_node_goes_on(moveit):
    rng = random.Random(3)
    pose = pose_of(np.eye(4))
    grasps = grasps_on(moveit.world.a_in_b("table", "camera"), 3, rng)

    def refused(obj: dict, gs: list[dict], words: str):
        rs = moveit.call(obj, gs)["recommendation_set"]
        assert rs["status"] == 2 and words in rs["message"], rs["message"]

    refused({"id": "cup"}, grasps, 'object "cup" is not known')
    # An object the table has no entry for, sent whole.
    refused(box_object("nomass", "table", pose, pose), grasps,
            'object "nomass" has no mass and friction: give it an entry under objects: in the file the parameter '
            'objects_file names')
    # Two shapes.
    two = box_object("box", "table", pose, pose)
    two["primitives"] *= 2
    two["primitive_poses"] *= 2
    refused(two, grasps, "2 primitives and 0 meshes")
    # Grasps in a frame not joined to world: tf2's words, naming both frames.
    lost = copy.deepcopy(grasps)
    for g in lost:
        g["grasp_pose"]["header"]["frame_id"] = "nowhere"
    refused(box_object("box", "table", pose, pose), lost, 'no transform of the gravity from frame "world" to frame '
                                                          '"nowhere"')
    # Grasps in two frames.
    mixed = copy.deepcopy(grasps)
    mixed[1]["grasp_pose"]["header"]["frame_id"] = "base"
    refused(box_object("box", "table", pose, pose), mixed, 'grasps[1] is in frame "base", grasps[0] in "camera"')
    # And the next good call is answered.
    good = moveit.call(box_object("box", "table", pose, pose), grasps)
    assert good["recommendation_set"]["status"] == 0, good["recommendation_set"]["message"]
    assert len(good["recommendation_set"]["recommendations"]) == 3


def test_a_recording_of_rank_grasps_replays_as_pose_sets(start_node, peer, tmp_path):
    """A node of its own, recording: its rank_grasps calls are recorded as pose sets, turned by TF, with their
    answers, and `grasp_orient replay` (no TF, no MoveIt, no objects_file) answers every one alike."""
    ns = "/moveit_replay"
    objects = tmp_path / "objects.yaml"
    objects.write_text(TABLE)
    runs = tmp_path / "runs"
    n = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", "gravity_frame:=world", "-p", "tf_timeout:=10.0",
                   "-p", f"objects_file:={objects}", "-p", "record:=true", "-p", f"record_dir:={runs}",
                   name="grasp_orient node (MoveIt, recording)")
    world = World(random.Random(39))
    static_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                            durability=DurabilityPolicy.TRANSIENT_LOCAL)
    tf = peer.node.create_publisher(TFMessage, "/tf_static", static_qos)
    rank = peer.node.create_client(RankGrasps, f"{ns}/grasp_orient/rank_grasps")
    try:
        # Published once the node's reader is there; kept (transient-local) for it however late it matches.
        assert peer.spin_until(lambda: tf.get_subscription_count() > 0, 15.0), "the node did not subscribe /tf_static"
        tf.publish(TFMessage(transforms=world.messages()))
        assert rank.wait_for_service(timeout_sec=15.0), "no ~/rank_grasps"
        peer.spin_for(0.5)
        rng = random.Random(5)
        for k in range(3):
            pose, shape_pose = rand_transform(rng), rand_transform(rng)
            obj = box_object("box", "table", pose_of(homogeneous(*pose)), pose_of(homogeneous(*shape_pose)))
            shape_in_table = homogeneous(*pose) @ homogeneous(*shape_pose)
            grasps = grasps_on(world.a_in_b("table", "camera") @ shape_in_table, 6, rng)
            req = RankGrasps.Request()
            pc.fill(req.object, obj)
            req.grasps = [pc.fill(Grasp(), g) for g in grasps]
            req.width = 0.09
            a = to_plain(peer.call(rank, req, timeout=30.0))
            assert a["recommendation_set"]["status"] == 0, a["recommendation_set"]["message"]
            assert a["grasps"], a["recommendation_set"]
    finally:
        peer.node.destroy_client(rank)
        peer.node.destroy_publisher(tf)
        n.stop_and_check()
    bags = sorted(runs.glob("*.mcap"))
    assert len(bags) == 1, bags
    r = subprocess.run([str(binary_path()), "replay", str(bags[0])], capture_output=True, text=True, timeout=120)
    out = r.stdout + r.stderr
    assert r.returncode == 0, out[-3000:]
    for words in ("3 pose sets, 3 recorded pose set answers",
                  "18 compared with a recorded recommendation, 0 differ beyond 1e-9, 0 recorded recommendations unmatched",
                  "3 sets (their candidates counted above): 3 compared with a recorded answer, 0 differ"):
        assert words in out, out[-3000:]


def test_a_mesh_resource_with_no_mass_takes_the_tables(moveit, peer):
    """A pose set on ~/recommend_poses and one on its topic naming the block's package:// resource with mass
    and friction 0 and no centre of mass: answered as solve answers the same poses with the table's mass,
    friction and centre of mass. An object without a resource (its mesh inline) is not looked up: refused for
    its mass."""
    rng = random.Random(6)
    obj = {**pc.objects()["package"], "mass": 0.0, "friction": 0.0}
    at = matrix_of(obj["pose"])
    poses = [{"id": f"p{k}", "grasp_pose": pose_of(at @ homogeneous([rng.uniform(-0.01, 0.01), 0.0, 0.0],
                                                                    [0.0, 0.0, math.sin(t / 2), math.cos(t / 2)])),
              "width": 0.09} for k, t in enumerate([0.0, 0.3, -0.4, 1.2])]
    pset = {"header": {"frame_id": "world"}, "id": "table-mesh", "object": obj, "poses": poses,
            "gravity": {"x": 0.0, "y": 0.0, "z": -9.80665}}
    service = peer.node.create_client(RecommendPoses, f"{NODE_NS}/grasp_orient/recommend_poses")
    try:
        req = RecommendPoses.Request()
        req.pose_set = pc.fill(PoseCandidateSet(), pset)
        got = to_plain(peer.call(service, req, timeout=30.0).recommendation_set)
    finally:
        peer.node.destroy_client(service)
    filled = {**obj, "mass": 0.35, "friction": 0.45, "has_center_of_mass": True,
              "center_of_mass": {"x": 0.002, "y": 0.001, "z": -0.003}}
    want = run_solve([{"header": {"frame_id": "world", "stamp": {"sec": 0, "nanosec": 0}}, "id": p["id"],
                       "grasp_pose": p["grasp_pose"], "width": p["width"], "object": filled,
                       "gravity": pset["gravity"]} for p in poses])
    assert got["status"] == 0, got["message"]
    diffs = close(without_tool_poses(got)["recommendations"], [without_tool_poses(w) for w in want])
    assert not diffs, diffs[:5]
    assert sum(r["recommendation"]["status"] == 0 for r in got["recommendations"]) >= 3
    # On the topic too; and an inline mesh, which names no resource, keeps its mass 0 and is refused.
    answers: dict[str, object] = {}
    pub = peer.node.create_publisher(PoseCandidateSet, f"{NODE_NS}/pose_candidate_sets", reliable_qos(10))
    sub = peer.node.create_subscription(PoseRecommendationSet, f"{NODE_NS}/pose_recommendation_sets",
                                        lambda m: answers.setdefault(m.set_id, m), reliable_qos(10))
    try:
        assert peer.spin_until(lambda: pub.get_subscription_count() > 0 and sub.get_publisher_count() > 0, 15.0)
        other = copy.deepcopy(pset)
        other["id"] = "no-entry"
        other["object"] = {**pc.objects()["inline"], "mass": 0.0}
        for s in (pset, other):
            pub.publish(pc.fill(PoseCandidateSet(), s))
        assert peer.spin_until(lambda: {"table-mesh", "no-entry"} <= set(answers), 30.0), sorted(answers)
    finally:
        peer.node.destroy_publisher(pub)
        peer.node.destroy_subscription(sub)
    on_topic = to_plain(answers["table-mesh"])
    assert not close(without_tool_poses(on_topic)["recommendations"], [without_tool_poses(w) for w in want])
    refused = to_plain(answers["no-entry"])["recommendations"]
    assert all(r["recommendation"]["status"] == 2 and "object.mass must be greater than zero" in
               r["recommendation"]["message"] for r in refused), refused[0]["recommendation"]["message"]


def test_grasps_in_many_frame_trees_equal_solve(moveit):
    """30 more trees, each turned and moved at random (world -> base_k -> camera_k, world -> table_k), published
    in one /tf_static message as a static broadcaster does; per tree a box given whole in the call, in table_k,
    and grasps in camera_k: every answer equals solve's on the pose candidates turned by numpy."""
    rng = random.Random(7)
    worlds = [World(rng, f"_{k}") for k in range(30)]
    moveit.tf.publish(TFMessage(transforms=moveit.world.messages() + [m for w in worlds for m in w.messages()]))
    held = 0
    for w in worlds:
        pose, shape_pose = rand_transform(rng), rand_transform(rng)
        obj = box_object("box", w.frame("table"), pose_of(homogeneous(*pose)), pose_of(homogeneous(*shape_pose)))
        shape_in_table = homogeneous(*pose) @ homogeneous(*shape_pose)
        grasps = grasps_on(w.a_in_b("table", "camera") @ shape_in_table, 5, rng, w.frame("camera"))
        answer = moveit.until(obj, grasps, lambda a: "no transform" not in a["recommendation_set"]["message"])
        cands = expected(w, "table", shape_in_table, {"primitive": {"type": 1, "dimensions": BOX}}, grasps,
                         MASS, FRICTION)
        held += check(moveit, answer, grasps, cands, w)
    assert held >= 100, held


def test_without_gravity_frame_the_parameter_holds_in_the_grasps_frame(start_node, peer, tmp_path):
    """A node without gravity_frame: a call's gravity is the parameter `gravity`, taken as given in the grasps'
    frame; the object, in that same frame, needs no TF at all."""
    ns = "/moveit_plain"
    objects = tmp_path / "objects.yaml"
    objects.write_text(TABLE)
    g = [1.5, -2.0, -9.0]
    n = start_node("--ros-args", "-r", f"__ns:={ns}", "-p", f"gravity:=[{g[0]}, {g[1]}, {g[2]}]",
                   "-p", f"objects_file:={objects}", "-p", "record:=false", name="grasp_orient node (no gravity_frame)")
    rank = peer.node.create_client(RankGrasps, f"{ns}/grasp_orient/rank_grasps")
    try:
        rng = random.Random(8)
        shape = homogeneous(*rand_transform(rng))
        obj = box_object("box", "gripper_base", pose_of(shape), pose_of(np.eye(4)))
        grasps = grasps_on(shape, 6, rng, "gripper_base")
        req = RankGrasps.Request()
        pc.fill(req.object, obj)
        req.grasps = [pc.fill(Grasp(), x) for x in grasps]
        req.width = 0.09
        got = to_plain(peer.call(rank, req, timeout=30.0))
    finally:
        peer.node.destroy_client(rank)
        n.stop_and_check()
    rs = got["recommendation_set"]
    assert rs["status"] == 0, rs["message"]
    cands = [{"header": {"frame_id": "gripper_base", "stamp": {"sec": 0, "nanosec": 0}}, "id": x["id"],
              "grasp_pose": x["grasp_pose"]["pose"], "width": 0.09,
              "object": {"pose": pose_of(shape), "scale": {"x": 1.0, "y": 1.0, "z": 1.0}, "mass": MASS,
                         "friction": FRICTION, "primitive": {"type": 1, "dimensions": BOX}},
              "gravity": vec(g)} for x in grasps]
    want = run_solve(cands)
    diffs = close(rs["recommendations"], want, "recommendations")
    assert not diffs, diffs[:5]
    assert sum(r["recommendation"]["status"] == 0 for r in rs["recommendations"]) >= 4
