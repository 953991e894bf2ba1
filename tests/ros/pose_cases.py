"""Pose candidates and pose sets (docs/poses.md) as JSON, shared by tests/ros/test_poses.py and
bags/record_node_poses.py, and their ROS messages.

The objects: a 40 x 60 x 80 mm block given inline (its corners and triangles, in millimetres, scale 0.001), the same
block named by `package://grasp_orient/meshes/block_mm.obj` (installed by CMakeLists.txt; the peer's build of this
package installs it too), and the four primitives. The gripper closes along its tool frame's y axis (the default
closing_axis), from `width` apart. A few are refused: a finger closing on nothing, a finger starting inside, a
scale of 0, a primitive with a scale, an unknown primitive type.
"""
from __future__ import annotations

import copy
import importlib
import math
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent.parent
BLOCK_RESOURCE = "package://grasp_orient/meshes/block_mm.obj"
T0 = 1_735_689_600_000_000_000  # 2025-01-01T00:00:00Z
PERIOD = 10_000_000


def stamp(k: int) -> dict:
    t = T0 + k * PERIOD
    return {"sec": t // 1_000_000_000, "nanosec": t % 1_000_000_000}


def block_mesh() -> dict:
    """meshes/block_mm.obj as a shape_msgs/Mesh dict (0-based indices, millimetres)."""
    vertices, triangles = [], []
    for line in (REPO_ROOT / "meshes" / "block_mm.obj").read_text().splitlines():
        f = line.split()
        if f and f[0] == "v":
            vertices.append({"x": float(f[1]), "y": float(f[2]), "z": float(f[3])})
        elif f and f[0] == "f":
            triangles.append({"vertex_indices": [int(i) - 1 for i in f[1:4]]})
    return {"vertices": vertices, "triangles": triangles}


def pose(x: float, y: float, z: float, yaw: float = 0.0) -> dict:
    return {"position": {"x": x, "y": y, "z": z},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


MM = {"x": 0.001, "y": 0.001, "z": 0.001}
ONE = {"x": 1.0, "y": 1.0, "z": 1.0}
GRAVITY = {"x": 0.0, "y": 0.0, "z": -9.81}


def objects() -> dict[str, dict]:
    at = pose(0.5, 0.0, 0.1, 0.3)
    base = {"pose": at, "mass": 0.25, "friction": 0.5}
    return {
        "inline": {**base, "inline_mesh": block_mesh(), "scale": MM},
        "package": {**base, "mesh": BLOCK_RESOURCE, "scale": MM},
        "box": {**base, "primitive": {"type": 1, "dimensions": [0.04, 0.06, 0.08]}, "scale": ONE},
        "sphere": {**base, "primitive": {"type": 2, "dimensions": [0.035]}, "scale": ONE},
        "cylinder": {**base, "primitive": {"type": 3, "dimensions": [0.12, 0.033]}, "scale": ONE},
        "cone": {**base, "primitive": {"type": 4, "dimensions": [0.1, 0.04]}, "scale": ONE},
    }


def grasps() -> list[tuple[str, dict, float]]:
    """(id, tool pose, width) on an object at (0.5, 0, 0.1): across it at three heights, one turned."""
    return [
        ("mid", pose(0.5, 0.0, 0.1, 0.3), 0.09),
        ("low", pose(0.5, 0.0, 0.08, 0.3), 0.09),
        ("off-centre", pose(0.505, 0.0, 0.11, 0.3), 0.09),
        ("turned", pose(0.5, 0.0, 0.1, 0.3 + math.pi / 2), 0.09),
    ]


def singles() -> list[dict]:
    """Single pose candidates: every grasp on every object, then the refused ones."""
    out = []
    objs = objects()
    for name, obj in objs.items():
        for gid, tool, width in grasps():
            out.append({"id": f"{name}-{gid}", "grasp_pose": tool, "width": width, "object": obj})
    refused_block = copy.deepcopy(objs["inline"])
    refused_block["scale"] = {"x": 0.0, "y": 0.001, "z": 0.001}
    scaled_box = copy.deepcopy(objs["box"])
    scaled_box["scale"] = MM
    unknown = copy.deepcopy(objs["box"])
    unknown["primitive"] = {"type": 7, "dimensions": [0.04]}
    out += [
        {"id": "refused-nothing", "grasp_pose": pose(1.5, 0.0, 0.1), "width": 0.09, "object": objs["package"]},
        {"id": "refused-inside", "grasp_pose": pose(0.5, 0.0, 0.1, 0.3), "width": 0.02, "object": objs["box"]},
        {"id": "refused-scale", "grasp_pose": pose(0.5, 0.0, 0.1, 0.3), "width": 0.09, "object": refused_block},
        {"id": "refused-primitive-scale", "grasp_pose": pose(0.5, 0.0, 0.1, 0.3), "width": 0.09,
         "object": scaled_box},
        {"id": "refused-type", "grasp_pose": pose(0.5, 0.0, 0.1, 0.3), "width": 0.09, "object": unknown},
    ]
    for k, c in enumerate(out):
        c["header"] = {"frame_id": "base_link", "stamp": stamp(k)}
        c["gravity"] = GRAVITY
    return out


def sets() -> list[dict]:
    """Pose sets: on the inline block, on the package:// block, on the cylinder (one pose closing on nothing in
    each), and a set on an unknown primitive (every pose refused)."""
    objs = objects()
    members = [{"id": gid, "grasp_pose": tool, "width": width} for gid, tool, width in grasps()]
    members.append({"id": "miss", "grasp_pose": pose(1.5, 0.0, 0.1), "width": 0.09})
    unknown = copy.deepcopy(objs["box"])
    unknown["primitive"] = {"type": 7, "dimensions": [0.04]}
    out = []
    for k, (sid, obj, limit) in enumerate([("set-inline", objs["inline"], 0.0), ("set-package", objs["package"], 0.0),
                                          ("set-cylinder", objs["cylinder"], 4.0), ("set-refused", unknown, 0.0)]):
        out.append({"header": {"frame_id": "base_link", "stamp": stamp(100 + k)}, "id": sid, "object": obj,
                    "poses": members, "gravity": GRAVITY, "max_grip_force": limit})
    return out


def _message_class(field_type: str):
    """'sequence<grasp_orient/GraspPose>' or 'grasp_orient/GraspPose[3]' -> the class."""
    name = field_type.removeprefix("sequence<").split(">")[0].split("[")[0]
    package, _, msg = name.partition("/")
    return getattr(importlib.import_module(f"{package}.msg"), msg)


def fill(msg, data: dict):
    """Sets a ROS message's fields from a JSON dict, lists of messages included."""
    types = msg.get_fields_and_field_types()
    for k, v in data.items():
        if isinstance(v, dict):
            fill(getattr(msg, k), v)
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            cls = _message_class(types[k])
            setattr(msg, k, [fill(cls(), x) for x in v])
        else:
            setattr(msg, k, v)
    return msg
