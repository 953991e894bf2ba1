#!/usr/bin/env python3
"""Play a MoveIt-style pick against a running grasp_orient node: TF, a collision object, grasps in a camera
frame, ~/rank_grasps, then ~/grip with the best grasp.

    source "$(bash tests/peer/setup.sh | tail -n 1)"      # rclpy, tf2_msgs, moveit_msgs, control_msgs (once)
    target/debug/grasp_orient node --ros-args -p gravity_frame:=world \\
        -p objects_file:=examples/pick_objects.yaml -p gripper_action:=/gripper_controller/gripper_cmd &
    python examples/pick.py --fake-gripper                  # no robot: this script is the gripper controller
    python examples/pick.py --ns /robot1 --action /robot1/gripper_controller/gripper_cmd --fake-gripper
                                                            # a node started with -r __ns:=/robot1

What it does, as a MoveIt 2 / ros2_control stack would (docs/moveit.md):
1. publishes a static transform tree on /tf_static, as tf2_ros's StaticTransformBroadcaster does:
   world -> base_link (the robot's base, moved and turned about z) -> camera_link (moved and turned
   arbitrarily, looking down at the table);
2. publishes the box `pick_box` as a moveit_msgs/CollisionObject (ADD) on /collision_object, in base_link, and
   sends it again until the node has it (a volatile sample sent before the node's reader matched is lost);
   its mass and friction come from the node's objects_file (examples/pick_objects.yaml);
3. builds a handful of moveit_msgs/Grasp around the box, their grasp_pose in camera_link (the fingers close
   along the tool frame's y, the node's default closing_axis);
4. calls ~/rank_grasps with the box by id and prints the ranked grasps: id, grip force (max_contact_force, N),
   grasp_quality and the tool pose to carry the box in (in world, the gravity_frame);
5. calls ~/grip with the best grasp's id and prints what the gripper's action got and its result. With
   --fake-gripper this script also serves the control_msgs/action/GripperCommand action named by --action (it
   must be the node's gripper_action), as ros2_control's gripper controller would, and prints the goal.

The last line printed is one JSON object summarising the run (the ranked grasps with their forces, the force
sent, the goal's max_effort the fake gripper received), for a program to read. Exit status: 0 when a grasp was
ranked and the gripper's goal succeeded; 1 otherwise (no node, a refusal, no gripper), saying why on stderr.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

# The scene. Each transform: parent, child, translation (m), roll-pitch-yaw (rad, as tf2's Quaternion.setRPY:
# about the fixed x, then y, then z axes).
TREE = [
    ("world", "base_link", (0.20, -0.10, 0.75), (0.0, 0.0, 0.5)),
    ("base_link", "camera_link", (0.30, -0.25, 0.55), (-2.4, 0.15, 1.1)),
]
GRAVITY_FRAME = "world"
BOX_ID = "pick_box"
BOX_FRAME = "base_link"
BOX_SIZE = (0.05, 0.07, 0.12)  # m, along the box's x, y, z (shape_msgs/SolidPrimitive BOX)
BOX_POSITION = (0.55, 0.05, 0.06)  # m, in BOX_FRAME: standing on the base's plane
BOX_RPY = (0.0, 0.0, 0.35)
CAMERA_FRAME = "camera_link"
# The grasps: id, the tool frame's offset (m) and roll-pitch-yaw (rad) in the box's frame. The fingers close
# along the tool's y: "side" grasps across the box's 7 cm, "end" grasps (turned a quarter about z) across its
# 5 cm, from an opening of WIDTH.
GRASPS = [
    ("side-center", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ("side-high", (0.0, 0.0, 0.03), (0.0, 0.0, 0.25)),
    ("side-low", (0.005, 0.0, -0.035), (0.0, 0.0, -0.3)),
    ("side-tilted", (0.0, 0.0, 0.01), (0.0, 0.5, 0.0)),
    ("end-low", (0.0, 0.006, -0.02), (0.0, 0.0, math.pi / 2 - 0.1)),
    ("end-high", (0.0, 0.0, 0.04), (0.0, 0.0, math.pi / 2 + 0.2)),
]
WIDTH = 0.09  # m
FINGER_JOINTS = ["left_finger_joint", "right_finger_joint"]
SUCCEEDED = 4  # action_msgs/GoalStatus


# Rigid transforms as (translation, quaternion (x, y, z, w)), composed in plain Python.
def quaternion_rpy(roll: float, pitch: float, yaw: float) -> tuple:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def q_mul(a: tuple, b: tuple) -> tuple:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def rotate(q: tuple, v: tuple) -> tuple:
    x, y, z, _ = q_mul(q_mul(q, (*v, 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def compose(a: tuple, b: tuple) -> tuple:
    """The transform b followed by a: a point p of b's frame is a(b(p))."""
    (ta, qa), (tb, qb) = a, b
    r = rotate(qa, tb)
    return ((ta[0] + r[0], ta[1] + r[1], ta[2] + r[2]), q_mul(qa, qb))


def inverse(a: tuple) -> tuple:
    t, q = a
    qi = (-q[0], -q[1], -q[2], q[3])
    r = rotate(qi, t)
    return ((-r[0], -r[1], -r[2]), qi)


def transform(t, rpy) -> tuple:
    return (tuple(t), quaternion_rpy(*rpy))


def box_in_camera() -> tuple:
    """The box's pose in the camera's frame, through the tree (the camera in base_link is its second edge)."""
    camera_in_base = transform(*TREE[1][2:])
    return compose(inverse(camera_in_base), transform(BOX_POSITION, BOX_RPY))


def grasp_poses_in_camera() -> list[tuple]:
    """(id, tool pose in camera_link) of each of GRASPS: the box's pose composed with the grasp's offset."""
    box = box_in_camera()
    return [(gid, compose(box, transform(t, rpy))) for gid, t, rpy in GRASPS]


def fail(msg: str) -> int:
    print(f"pick: {msg}", file=sys.stderr)
    return 1


def pose_msg(p: tuple):
    from geometry_msgs.msg import Pose
    m = Pose()
    (m.position.x, m.position.y, m.position.z), (m.orientation.x, m.orientation.y, m.orientation.z,
                                                 m.orientation.w) = p
    return m


def static_transforms():
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
    out = []
    for parent, child, t, rpy in TREE:
        m = TransformStamped()
        m.header.frame_id, m.child_frame_id = parent, child  # stamp 0: static transforms hold at every time
        (m.transform.translation.x, m.transform.translation.y, m.transform.translation.z) = t
        (m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z,
         m.transform.rotation.w) = quaternion_rpy(*rpy)
        out.append(m)
    return TFMessage(transforms=out)


def collision_object():
    from moveit_msgs.msg import CollisionObject
    from shape_msgs.msg import SolidPrimitive
    obj = CollisionObject(id=BOX_ID, operation=CollisionObject.ADD)
    obj.header.frame_id = BOX_FRAME
    obj.pose = pose_msg(transform(BOX_POSITION, BOX_RPY))
    obj.primitives = [SolidPrimitive(type=SolidPrimitive.BOX, dimensions=list(BOX_SIZE))]
    obj.primitive_poses = [pose_msg(((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))]
    return obj


def grasps():
    from moveit_msgs.msg import Grasp
    from trajectory_msgs.msg import JointTrajectoryPoint
    out = []
    for gid, pose in grasp_poses_in_camera():
        g = Grasp(id=gid)
        g.grasp_pose.header.frame_id = CAMERA_FRAME  # stamp 0: the latest transforms
        g.grasp_pose.pose = pose_msg(pose)
        g.grasp_posture.joint_names = list(FINGER_JOINTS)
        g.grasp_posture.points = [JointTrajectoryPoint(positions=[0.0] * len(FINGER_JOINTS))]
        out.append(g)
    return out


class FakeGripper:
    """A control_msgs/action/GripperCommand server, as ros2_control's gripper controller offers one: it accepts
    each goal, prints it, and ends it at once, stalled on the object at the commanded effort."""

    def __init__(self, node, name: str):
        from control_msgs.action import GripperCommand
        from rclpy.action import ActionServer, GoalResponse
        self.type = GripperCommand
        self.goals: list = []
        self.accept = GoalResponse.ACCEPT
        self.server = ActionServer(node, GripperCommand, name, execute_callback=self._execute,
                                   goal_callback=self._goal)
        self.name = name

    def _goal(self, goal):
        self.goals.append(goal)
        return self.accept

    def _execute(self, handle):
        cmd = handle.request.command
        print(f"fake gripper {self.name}: goal command.position {cmd.position:g}, "
              f"command.max_effort {cmd.max_effort:.6g} N")
        result = self.type.Result(position=cmd.position, effort=cmd.max_effort, stalled=True, reached_goal=False)
        handle.succeed()
        return result


def tool_pose_text(tp) -> str:
    p, o = tp.pose.position, tp.pose.orientation
    return (f"tool pose in {tp.header.frame_id!r}: position ({p.x:.4f}, {p.y:.4f}, {p.z:.4f}) m, "
            f"orientation ({o.x:.4f}, {o.y:.4f}, {o.z:.4f}, {o.w:.4f})")


def finite(x: float) -> float | None:
    """x, or None where it is inf or NaN (JSON has neither)."""
    return x if math.isfinite(x) else None


def tool_pose_json(tp) -> dict:
    p, o = tp.pose.position, tp.pose.orientation
    return {"frame_id": tp.header.frame_id, "position": [p.x, p.y, p.z], "orientation": [o.x, o.y, o.z, o.w]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ns", default="", help="namespace of the node (e.g. /robot1; default: none)")
    ap.add_argument("--name", default="grasp_orient", help="name of the node (default grasp_orient)")
    ap.add_argument("--action", default="/gripper_controller/gripper_cmd",
                    help="the GripperCommand action the fake gripper serves: the node's gripper_action, fully "
                         "qualified (default /gripper_controller/gripper_cmd)")
    ap.add_argument("--fake-gripper", action="store_true",
                    help="serve the GripperCommand action at --action here (no robot needed)")
    ap.add_argument("--max-grip-force", type=float, default=0.0,
                    help="N: the most the gripper gives, for ~/rank_grasps (default 0: the node's max_grip_force)")
    ap.add_argument("--timeout", type=float, default=20.0,
                    help="seconds to wait for the node, its services and the answers (default 20)")
    args = ap.parse_args()

    try:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from moveit_msgs.msg import CollisionObject
        from grasp_orient.srv import Grip, RankGrasps
        from tf2_msgs.msg import TFMessage
    except ImportError as e:
        return fail(f"{e}: source the ROS peer first (source \"$(bash tests/peer/setup.sh | tail -n 1)\")")

    node_path = f"{args.ns.rstrip('/')}/{args.name}"
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    rclpy.init()
    try:
        node = rclpy.create_node("pick_example")
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        deadline = time.monotonic() + args.timeout

        def left() -> float:
            return max(0.0, deadline - time.monotonic())

        # 1. The static transforms, with tf2_ros's StaticTransformBroadcaster's QoS: kept for late joiners.
        static_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
        tf = node.create_publisher(TFMessage, "/tf_static", static_qos)
        tf.publish(static_transforms())
        objects = node.create_publisher(CollisionObject, "/collision_object", 10)
        gripper = FakeGripper(node, args.action) if args.fake_gripper else None
        rank = node.create_client(RankGrasps, f"{node_path}/rank_grasps")
        grip = node.create_client(Grip, f"{node_path}/grip")

        def call(client, request):
            if not client.wait_for_service(timeout_sec=left()):
                raise TimeoutError(f"no service {client.srv_name} within {args.timeout:g} s: is grasp_orient node "
                                   f"running on ROS_DOMAIN_ID={domain} (namespace {args.ns or '/'})?")
            future = client.call_async(request)
            executor.spin_until_future_complete(future, timeout_sec=left())
            if not future.done():
                raise TimeoutError(f"no response from {client.srv_name} within {args.timeout:g} s")
            return future.result()

        # 2-4. The box, the grasps, the ranking: until the node has heard the box and the transforms.
        request = RankGrasps.Request(object=CollisionObject(id=BOX_ID), grasps=grasps(), width=WIDTH,
                                     max_grip_force=args.max_grip_force)
        box = collision_object()
        while True:
            objects.publish(box)
            executor.spin_once(timeout_sec=0.05)
            ranked = call(rank, request)
            rs = ranked.recommendation_set
            waiting = "is not known" in rs.message or "no transform" in rs.message
            if not waiting or left() == 0.0:
                break
            executor.spin_once(timeout_sec=0.2)
        if rs.status != 0 or not ranked.grasps:
            return fail(f"~/rank_grasps ranked no grasp: set status {rs.status}: {rs.message or '-'}; "
                        + "; ".join(f"{r.recommendation.candidate_id}: status {r.recommendation.status} "
                                    f"{r.recommendation.message}" for r in rs.recommendations))
        print(f"ranked {len(ranked.grasps)} of {len(request.grasps)} grasps of {BOX_ID!r}, least grip force first:")
        summary = {"object": BOX_ID, "ranked": [], "not_ranked": []}
        for k, (i, g) in enumerate(zip(ranked.indices, ranked.grasps)):
            answer = rs.recommendations[i]
            r = answer.recommendation
            print(f"  {k + 1}  {g.id:<12} grip force {g.max_contact_force:8.4f} N  quality {g.grasp_quality:.3f}  "
                  f"wrist rotation {math.degrees(r.wrist_rotation):7.2f} deg  {tool_pose_text(answer.tool_pose)}  "
                  f"(internal_force_current, at the grasp pose before the turn: {r.internal_force_current:.4f} N)")
            summary["ranked"].append({"id": g.id, "index": int(i), "max_contact_force": g.max_contact_force,
                                      "internal_force": r.internal_force, "finger_force": r.finger_force,
                                      "internal_force_current": finite(r.internal_force_current),
                                      "wrist_rotation": r.wrist_rotation,
                                      "grasp_quality": g.grasp_quality, "tool_pose": tool_pose_json(answer.tool_pose)})
        for answer in rs.recommendations:
            r = answer.recommendation
            if r.candidate_id not in {g.id for g in ranked.grasps}:
                print(f"  -  {r.candidate_id:<12} status {r.status}: {r.message}")
                summary["not_ranked"].append({"id": r.candidate_id, "status": r.status, "message": r.message})

        # 5. The gripper: the best grasp's force, times grip_safety_factor, capped, as the action's goal.
        best = ranked.grasps[0].id
        g = call(grip, Grip.Request(grasp_id=best))
        print(f"~/grip {best!r}: recommended {g.recommended_force:.6g} N, sent {g.force:.6g} N to "
              f"{g.action or '-'}: {g.message}")
        if g.sent:
            print(f"  result: goal_status {g.goal_status}, position {g.position:g}, effort {g.effort:.6g}, "
                  f"stalled {g.stalled}, reached_goal {g.reached_goal}")
        received = [goal.command.max_effort for goal in gripper.goals] if gripper is not None else []
        summary.update(best=best, recommended_force=g.recommended_force, force_sent=g.force, action=g.action,
                       sent=g.sent, goal_status=g.goal_status, gripper_goals=len(received),
                       gripper_max_effort=received[-1] if received else None)
        print(json.dumps(summary, allow_nan=False))
        if not g.sent or g.goal_status != SUCCEEDED:
            return fail(f"the gripper's goal did not succeed (sent {g.sent}, goal_status {g.goal_status}): "
                        f"{g.message}")
        node.destroy_node()
        return 0
    except TimeoutError as e:
        return fail(str(e))
    finally:
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
