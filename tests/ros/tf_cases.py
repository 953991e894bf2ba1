"""TF cases as numpy computes them, shared by tests/ros/test_tf.py and bags/record_node_tf.py: quaternions (x, y, z,
w) to matrices and back, slerp, transforms composed along a frame tree, random frame trees with one moving
transform sampled at two stamps. Nothing here shares code with the node's TF (src/tf/): it is the independent
computation the node's answers are held to.
"""
from __future__ import annotations

import math
import random

import numpy as np

NS = 1_000_000_000
GRAVITY = np.array([0.0, 0.0, -9.80665])  # the parameter gravity's default, in world
T1, T2 = 1000 * NS, 1002 * NS  # the moving transforms' two samples


def matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def homogeneous(t, q) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = matrix(q)
    m[:3, 3] = t
    return m


def slerp(q1, q2, r) -> np.ndarray:
    """The rotation a fraction r of the way from q1 to q2 along the shorter arc."""
    q1, q2 = np.asarray(q1, float), np.asarray(q2, float)
    d = float(np.dot(q1, q2))
    if d < 0:
        q2, d = -q2, -d
    theta = math.acos(min(1.0, d))
    if theta < 1e-12:
        return q1
    return (math.sin((1 - r) * theta) * q1 + math.sin(r * theta) * q2) / math.sin(theta)


def quaternion_of(m: np.ndarray) -> np.ndarray:
    """(x, y, z, w) of a rotation matrix (Shepperd's method), w >= 0."""
    tr = np.trace(m)
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = math.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k]) * 2
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i] = 0.25 * s
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
    q = np.array(q)
    return -q if q[3] < 0 else q


def random_quaternion(rng: random.Random) -> list[float]:
    q = np.array([rng.gauss(0, 1) for _ in range(4)])
    return list(q / np.linalg.norm(q))


class Tree:
    """Frames t<k>_f<i> below world; each has a static transform to its parent but one, which moves: sampled at
    T1 and T2, turned by less than 2.5 rad between them."""

    def __init__(self, rng: random.Random, k: int):
        self.frames = ["world"]
        self.parent: dict[str, str] = {}
        self.static: dict[str, tuple] = {}
        for i in range(rng.randint(2, 5)):
            name = f"t{k}_f{i}"
            self.parent[name] = rng.choice(self.frames)
            self.frames.append(name)
            t = [rng.uniform(-1, 1) for _ in range(3)]
            self.static[name] = (t, random_quaternion(rng))
        self.moving = rng.choice(self.frames[1:])
        t1, q1 = self.static.pop(self.moving)
        axis = np.array([rng.gauss(0, 1) for _ in range(3)])
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(0.1, 2.5)
        turn = np.array([*(axis * math.sin(angle / 2)), math.cos(angle / 2)])
        q2 = quaternion_of(matrix(q1) @ matrix(turn))
        if np.dot(q1, q2) < 0:
            q2 = -q2
        t2 = [c + rng.uniform(-0.5, 0.5) for c in t1]
        self.samples = ((T1, t1, q1), (T2, t2, list(q2)))

    def edge(self, frame: str, stamp: int) -> np.ndarray:
        """T_parent_frame at stamp (0: the latest sample)."""
        if frame != self.moving:
            return homogeneous(*self.static[frame])
        (a, ta, qa), (b, tb, qb) = self.samples
        if stamp == 0:
            stamp = b
        r = (stamp - a) / (b - a)
        t = np.array(ta) + r * (np.array(tb) - np.array(ta))
        return homogeneous(t, slerp(qa, qb, r))

    def crosses_moving(self, frame: str) -> bool:
        """Whether the way from world down to frame takes the moving transform."""
        while frame != "world":
            if frame == self.moving:
                return True
            frame = self.parent[frame]
        return False

    def in_world(self, frame: str, stamp: int) -> np.ndarray:
        """T_world_frame: the edges from world down to frame, composed."""
        m = np.eye(4)
        while frame != "world":
            m = self.edge(frame, stamp) @ m
            frame = self.parent[frame]
        return m


def transform_msg(parent: str, child: str, stamp: int, t, q):
    """A geometry_msgs/TransformStamped: `child` in `parent` at `stamp` (ns), translation t, rotation q."""
    from geometry_msgs.msg import TransformStamped
    m = TransformStamped()
    m.header.frame_id = parent
    m.header.stamp.sec, m.header.stamp.nanosec = stamp // NS, stamp % NS
    m.child_frame_id = child
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = map(float, t)
    m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z, m.transform.rotation.w = map(float, q)
    return m


def stamp_of(ns: int) -> dict:
    return {"sec": ns // NS, "nanosec": ns % NS}


def vec(v) -> dict:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def pose_of(m: np.ndarray) -> dict:
    q = quaternion_of(m[:3, :3])
    return {"position": vec(m[:3, 3]),
            "orientation": {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}}


def matrix_of(p: dict) -> np.ndarray:
    o = p["orientation"]
    pos = p["position"]
    return homogeneous([pos["x"], pos["y"], pos["z"]], [o["x"], o["y"], o["z"], o["w"]])


def rodrigues(k, phi: float) -> np.ndarray:
    """The rotation by phi about the unit axis k: I + sin(phi) K + (1 - cos(phi)) K^2."""
    k = np.asarray(k, float)
    kk = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(phi) * kk + (1 - math.cos(phi)) * kk @ kk


def tool_pose_by_numpy(grasp_pose: dict, answer: dict) -> np.ndarray:
    """The tool pose to carry the object in (docs/poses.md, "The tool pose"), as a 4x4 matrix in the candidate's
    header frame: the gripper pose turned by the answer's rotation (Rodrigues from `rotation_axis` and
    `wrist_rotation`, not the answer's quaternion) about the midpoint m of its contacts: R R_tool at
    m + R (t - m). `answer` is a PoseRecommendation as a dict."""
    r = answer["recommendation"]
    axis = r["rotation_axis"]
    rot = rodrigues([axis["x"], axis["y"], axis["z"]], r["wrist_rotation"])
    o = grasp_pose["orientation"]
    q = np.array([o["x"], o["y"], o["z"], o["w"]])
    tool = homogeneous([grasp_pose["position"][c] for c in "xyz"], q / np.linalg.norm(q))
    c1, c2 = (np.array([answer[k][c] for c in "xyz"]) for k in ("contact_1", "contact_2"))
    m = (c1 + c2) / 2
    out = np.eye(4)
    out[:3, :3] = rot @ tool[:3, :3]
    out[:3, 3] = m + rot @ (tool[:3, 3] - m)
    return out


def tool_pose_gap(got: dict, want: np.ndarray) -> float:
    """The largest difference between a tool pose (a geometry_msgs/Pose as a dict) and a 4x4 matrix: of the
    position relative to max(1, |x|), and of the rotation matrices' entries."""
    m = matrix_of(got)
    position = max(abs(a - b) / max(1.0, abs(a), abs(b)) for a, b in zip(m[:3, 3], want[:3, 3]))
    return max(position, float(np.max(np.abs(m[:3, :3] - want[:3, :3]))))
