"""The grasp planner proxy ~/find_graspable_objects (docs/node.md#moveit), against an rclpy grasp planner over
Fast DDS.

grasping_msgs is built by tests/peer/setup.sh from its definitions (FindGraspableObjects.action and its messages,
verbatim). An rclpy `ActionServer` of grasping_msgs/action/FindGraspableObjects plays the planner the parameter
grasp_planner_action names: it returns objects with grasps in a camera frame of a static frame tree (published as
tf2_ros's StaticTransformBroadcaster does). An rclpy `ActionClient` calls the node's proxy. Each object's grasps
in the proxy's result must equal ~/rank_grasps' response on the same object and grasps, which itself must equal
`grasp_orient solve` on the equivalent PoseCandidates turned by numpy (test_moveit.py's helpers); an object the
node cannot answer (no mass) comes back with its grasps unranked, and everything else of the planner's result
(the point cluster, the support surfaces) as it came. A planner that rejects the goal, a planner that is not
there and a planner that keeps the goal past grasp_planner_timeout (its goal then canceled) each abort the proxy's
goal with a clear line in the log, and the node goes on answering.
Each node runs in a namespace of its own and is stopped at the module's end.
"""
from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from conftest import Peer, to_plain
from fake_action import FakeActionServer
import pose_cases as pc
from tf_cases import homogeneous, pose_of
from test_moveit import BOX, FRICTION, MASS, TABLE, World, check, expected, grasps_on, rand_transform

from ament_index_python.packages import get_package_share_directory  # noqa: E402
from grasping_msgs.action import FindGraspableObjects  # noqa: E402
from grasping_msgs.msg import GraspableObject, Object  # noqa: E402
from grasp_orient.srv import RankGrasps  # noqa: E402
from moveit_msgs.msg import Grasp  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import PointField  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

JAZZY = Path(__file__).resolve().parent.parent.parent / "src" / "msg" / "jazzy"
NODE_NS = "/grasp_proxy_case"
ABSENT_NS = "/grasp_proxy_absent"
SLOW_NS = "/grasp_proxy_slow"
PLANNER = f"{NODE_NS}/planner"
SUFFIX = "_proxy"  # this module's frames, apart from test_moveit.py's on the shared /tf_static
SUCCEEDED, ABORTED = 4, 6


def test_point_cloud2_is_the_wheels():
    """src/msg/jazzy/sensor_msgs/PointCloud2.msg and PointField.msg, which the node's wire structs are held to
    (src/msg/grasping.rs), are the texts the ros-sensor-msgs wheel (Jazzy) installs."""
    share = Path(get_package_share_directory("sensor_msgs"))
    for name in ("PointCloud2", "PointField"):
        assert (share / "msg" / f"{name}.msg").read_text() == (JAZZY / "sensor_msgs" / f"{name}.msg").read_text()


@pytest.fixture(scope="module")
def proxy_nodes(start_node, tmp_path_factory):
    """A node whose proxy forwards to PLANNER (gravity_frame world, the objects table, width 0.09 as
    test_moveit.expected takes it), one whose planner is not there, and one that forwards to PLANNER with
    grasp_planner_timeout 1 s."""
    objects = tmp_path_factory.mktemp("proxy") / "objects.yaml"
    objects.write_text(TABLE)
    common = ["-p", "record:=false", "-p", "gravity_frame:=world", "-p", "tf_timeout:=0.5",
              "-p", f"objects_file:={objects}", "-p", "grasp_planner_width:=0.09"]
    started = [
        start_node("--ros-args", "-r", f"__ns:={NODE_NS}", *common, "-p", "grasp_planner_action:=planner",
                   "-p", "grasp_planner_timeout:=10.0", name="grasp_orient node (grasp proxy)"),
        start_node("--ros-args", "-r", f"__ns:={ABSENT_NS}", *common, "-p", "grasp_planner_action:=nobody_home",
                   "-p", "grasp_planner_timeout:=1.0", name="grasp_orient node (no planner)"),
        start_node("--ros-args", "-r", f"__ns:={SLOW_NS}", *common, "-p", f"grasp_planner_action:={PLANNER}",
                   "-p", "grasp_planner_timeout:=1.0", name="grasp_orient node (slow planner)"),
    ]
    yield started
    for n in started:
        if n.proc.poll() is None:
            n.stop_and_check()


class Planner(FakeActionServer):
    """An rclpy FindGraspableObjects server, as a grasp planner offers it: it returns `result` (or rejects the
    goal while `reject` is set, or keeps it executing until canceled while `hold` is set) and records each goal
    and cancel."""

    def __init__(self, peer: Peer):
        super().__init__(peer.node, FindGraspableObjects, PLANNER)
        self.result = FindGraspableObjects.Result()

    def finish(self, handle):
        handle.succeed()
        return self.result


class Scene:
    """The peer's side: the static frame tree, the planner, a client of each node's proxy and ~/rank_grasps."""

    def __init__(self, peer: Peer):
        static_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.peer = peer
        self.world = World(random.Random(391), SUFFIX)
        self.tf = peer.node.create_publisher(TFMessage, "/tf_static", static_qos)
        self.planner = Planner(peer)
        self.proxy = ActionClient(peer.node, FindGraspableObjects, f"{NODE_NS}/grasp_orient/find_graspable_objects")
        self.absent = ActionClient(peer.node, FindGraspableObjects,
                                   f"{ABSENT_NS}/grasp_orient/find_graspable_objects")
        self.slow = ActionClient(peer.node, FindGraspableObjects, f"{SLOW_NS}/grasp_orient/find_graspable_objects")
        self.rank = peer.node.create_client(RankGrasps, f"{NODE_NS}/grasp_orient/rank_grasps")
        assert peer.spin_until(lambda: self.tf.get_subscription_count() >= 2, 15.0), "no node subscribes /tf_static"
        for c in (self.proxy, self.absent, self.slow):
            assert c.wait_for_server(timeout_sec=15.0), f"no action server {c._action_name}"
        assert self.rank.wait_for_service(timeout_sec=15.0), "no ~/rank_grasps"
        self.tf.publish(TFMessage(transforms=self.world.messages()))

    def find(self, client: ActionClient, timeout: float = 30.0):
        """Sends a goal; returns (status, result as a plain dict)."""
        goal = FindGraspableObjects.Goal(plan_grasps=True)
        sent = client.send_goal_async(goal)
        assert self.peer.spin_until(sent.done, timeout), "the proxy did not answer the goal"
        handle = sent.result()
        assert handle.accepted, "the proxy rejected the goal"
        got = handle.get_result_async()
        assert self.peer.spin_until(got.done, timeout), "no result from the proxy"
        r = got.result()
        return r.status, to_plain(r.result)

    def rank_grasps(self, obj: dict, grasps: list[dict]) -> dict:
        req = RankGrasps.Request()
        pc.fill(req.object, obj)
        req.grasps = [pc.fill(Grasp(), g) for g in grasps]
        req.width = 0.09
        return to_plain(self.peer.call(self.rank, req, timeout=30.0))


@pytest.fixture(scope="module")
def scene(peer, proxy_nodes):
    return Scene(peer)


def box(name: str, frame: str, shape_pose: dict) -> Object:
    """An Object as a planner describes it: a box whose pose is in the header frame, with a point cluster."""
    o = pc.fill(Object(), {"header": {"frame_id": frame}, "name": name, "support_surface": "table",
                           "primitives": [{"type": 1, "dimensions": BOX}], "primitive_poses": [shape_pose]})
    c = o.point_cluster
    c.header.frame_id, c.height, c.width, c.point_step, c.row_step = frame, 1, 2, 12, 24
    c.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xyz")]
    c.data = bytes(range(24))
    return o


def test_the_proxy_ranks_each_objects_grasps_as_rank_grasps_does(scene):
    """Two objects in a table frame, their grasps in a camera frame: "box" (in objects_file) comes back with its
    grasps ranked exactly as ~/rank_grasps ranks them (which equals solve's answer); "nomass" (no entry) with its
    grasps as the planner gave them; the clouds and the support surfaces as they came."""
    w = scene.world
    rng = random.Random(5)
    shape_pose = rand_transform(rng)
    shape_in_table = homogeneous(*shape_pose)
    grasps = grasps_on(w.a_in_b("table", "camera") @ shape_in_table, 10, rng, camera=w.frame("camera"))
    obj = box("box", w.frame("table"), pose_of(shape_in_table))
    unknown = box("nomass", w.frame("table"), pose_of(shape_in_table))
    result = FindGraspableObjects.Result()
    result.objects = [GraspableObject(object=obj, grasps=[pc.fill(Grasp(), g) for g in grasps]),
                      GraspableObject(object=unknown, grasps=[pc.fill(Grasp(), g) for g in grasps[:3]])]
    result.support_surfaces = [box("table", w.frame("table"), pose_of(np.eye(4)))]
    scene.planner.result = result
    sent = to_plain(result)

    collision = {"header": {"frame_id": w.frame("table")}, "id": "box",
                 "primitives": [{"type": 1, "dimensions": BOX}], "primitive_poses": [pose_of(shape_in_table)]}
    # The static tree may not have reached the node yet: ~/rank_grasps until it has.
    for _ in range(50):
        ranked = scene.rank_grasps(collision, grasps)
        if "no transform" not in ranked["recommendation_set"]["message"]:
            break
        scene.peer.spin_for(0.1)
    cands = expected(w, "table", shape_in_table, {"primitive": {"type": 1, "dimensions": BOX}}, grasps, MASS,
                     FRICTION)
    assert check(None, ranked, grasps, cands, w) >= 6

    status, got = scene.find(scene.proxy)
    assert status == SUCCEEDED
    assert len(scene.planner.goals) == 1 and scene.planner.goals[0].plan_grasps
    assert len(got["objects"]) == 2
    assert got["objects"][0]["grasps"] == ranked["grasps"]
    assert len(got["objects"][0]["grasps"]) < len(grasps) or ranked["indices"] != list(range(len(grasps)))
    assert got["objects"][1]["grasps"] == sent["objects"][1]["grasps"], "an object without mass comes back unranked"
    for i in range(2):
        assert got["objects"][i]["object"] == sent["objects"][i]["object"]
    assert got["support_surfaces"] == sent["support_surfaces"]


def test_unranked_objects_are_logged(scene, proxy_nodes):
    """The object the node could not answer is named in the log with the reason."""
    proxy_nodes[0].wait_for_line(r'find_graspable_objects: object "nomass": its 3 grasps are returned unranked: '
                                 r'status 2: .*no mass', timeout=10.0)


def test_a_rejected_goal_and_an_absent_planner_abort_and_the_node_goes_on(scene, proxy_nodes):
    """The planner rejects: the proxy's goal is aborted, the log says so. No planner at the name: aborted after
    grasp_planner_timeout, the log says so. Then the proxy answers the next goal."""
    scene.planner.reject = True
    try:
        status, got = scene.find(scene.proxy)
    finally:
        scene.planner.reject = False
    assert status == ABORTED and got["objects"] == []
    proxy_nodes[0].wait_for_line(r"find_graspable_objects: goal aborted: the action server at "
                                 rf"{PLANNER} rejected the goal", timeout=10.0)
    status, _ = scene.find(scene.absent)
    assert status == ABORTED
    proxy_nodes[1].wait_for_line(r"find_graspable_objects: goal aborted: no action server at "
                                 rf"{ABSENT_NS}/nobody_home \(none found within grasp_planner_timeout",
                                 timeout=10.0)
    status, got = scene.find(scene.proxy)
    assert status == SUCCEEDED and len(got["objects"]) == len(scene.planner.result.objects)
    assert all(n.proc.poll() is None for n in proxy_nodes)


def test_a_planner_without_a_result_in_time_is_canceled_and_the_goal_aborted(scene, proxy_nodes):
    """A planner that keeps the goal past grasp_planner_timeout (1 s): the node cancels the planner's goal and
    aborts its own, saying so; meanwhile and afterwards the other node's proxy answers."""
    scene.planner.hold = True
    try:
        sent = scene.slow.send_goal_async(FindGraspableObjects.Goal(plan_grasps=True))
        assert scene.peer.spin_until(sent.done, 10.0) and sent.result().accepted
        got = sent.result().get_result_async()
        assert scene.peer.spin_until(got.done, 10.0), "no result from the proxy"
    finally:
        scene.planner.hold = False
        if scene.planner.released is not None and not scene.planner.released.done():
            scene.planner.released.set_result(True)
    assert got.result().status == ABORTED
    assert scene.planner.cancels >= 1, "the planner's goal was not canceled"
    proxy_nodes[2].wait_for_line(rf"find_graspable_objects: goal aborted: the goal went to the planner at "
                                 rf"{PLANNER}, but no result came within grasp_planner_timeout \(1 s\); the goal "
                                 r"was canceled", timeout=10.0)
    status, got = scene.find(scene.proxy)
    assert status == SUCCEEDED and len(got["objects"]) == len(scene.planner.result.objects)
