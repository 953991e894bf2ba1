"""grasp_orient: the grip force of a two-finger grasp and the gravity orientation that minimises it.

Grasp datasets re-scored in numpy, without the ROS 2 node: every answer is the one
``grasp_orient solve`` gives for the same candidate (docs/python.md).

- :func:`solve`: rows of contacts, inward normals, centre of mass, gravity, mass and friction.
- :func:`solve_poses`: 4x4 gripper poses and openings on one mesh given as arrays.
- :func:`load_mesh`: an STL, OBJ or COLLADA file as vertex and triangle arrays.

Each returns a dict of arrays, one row per grasp, named as ``GripRecommendation``'s fields.
"""

from ._grasp_orient import load_mesh, solve, solve_poses

#: ``status`` values (msg/GripRecommendation.msg).
STATUS_OK = 0
STATUS_NO_FORCE_CLOSURE = 1
STATUS_INVALID_INPUT = 2
STATUS_EXCEEDS_GRIPPER = 3

__all__ = [
    "solve",
    "solve_poses",
    "load_mesh",
    "STATUS_OK",
    "STATUS_NO_FORCE_CLOSURE",
    "STATUS_INVALID_INPUT",
    "STATUS_EXCEEDS_GRIPPER",
]
