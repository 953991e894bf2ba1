"""Type stubs of grasp_orient (docs/python.md)."""

from typing import Dict, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

Floats = npt.NDArray[np.float64]
Indices = Union[
    npt.NDArray[np.int64], npt.NDArray[np.int32], npt.NDArray[np.uint32], npt.NDArray[np.uint64]
]
Vector = Union[Sequence[float], Floats]
Range = Union[Literal["from_above", "graspable"], Tuple[float, float]]
Answer = Dict[str, Union[Floats, npt.NDArray[np.uint8], List[str]]]

STATUS_OK: int
STATUS_NO_FORCE_CLOSURE: int
STATUS_INVALID_INPUT: int
STATUS_EXCEEDS_GRIPPER: int

def solve(
    contact_1: Floats,
    normal_1: Floats,
    contact_2: Floats,
    normal_2: Floats,
    center_of_mass: Floats,
    gravity: Floats,
    mass: Floats,
    friction: Floats,
    *,
    model: Literal["spatial", "planar"] = "spatial",
    objective: Literal["norm2", "norm1", "internal_force"] = "norm2",
    range: Optional[Range] = None,
    friction_safety_factor: float = 1.0,
    max_grip_force: float = 0.0,
    gripper_drive: Literal["coupled", "independent"] = "coupled",
    center_of_mass_tolerance: Optional[Vector] = None,
    mass_tolerance: float = 0.0,
    threads: Optional[int] = None,
) -> Answer:
    """Solve N grasps: (N, 3) float64 contacts, inward normals, centres of mass and gravity
    (m, m/s²), (N,) float64 masses (kg), and friction coefficients: (N,) for both contacts or
    (N, 2) one a contact. Returns a dict of arrays named
    as GripRecommendation's fields: status, wrist_rotation, rotation (N, 4 xyzw), rotation_axis,
    gripping_power, internal_force, finger_force, contact_forces, message (list of str), …
    Raises ValueError naming the argument and the row for a bad array or value."""

def solve_poses(
    vertices: Floats,
    triangles: Indices,
    poses: Floats,
    widths: Floats,
    mass: float,
    friction: float,
    gravity: Vector,
    *,
    closing_axis: Literal["x", "y", "z"] = "y",
    center_of_mass: Optional[Vector] = None,
    scale: Union[float, Vector, None] = None,
    objective: Literal["norm2", "norm1", "internal_force"] = "norm2",
    range: Optional[Range] = None,
    friction_safety_factor: float = 1.0,
    max_grip_force: float = 0.0,
    gripper_drive: Literal["coupled", "independent"] = "coupled",
    center_of_mass_tolerance: Optional[Vector] = None,
    mass_tolerance: float = 0.0,
    threads: Optional[int] = None,
) -> Answer:
    """Solve N gripper poses, (N, 4, 4) float64 homogeneous transforms of the tool frame in the
    mesh's frame, with (N,) openings (m), on one mesh: (V, 3) float64 vertices and (T, 3) integer
    triangles. Returns solve()'s fields and contact_1, contact_2, normal_1, normal_2,
    center_of_mass (N, 3; NaN where refused), grasp_orientation (N, 4 xyzw) and tool_pose
    (N, 7: x, y, z, qx, qy, qz, qw in the mesh's frame; the tool frame after the recommended
    rotation about the midpoint of the contacts; NaN where there is no rotation)."""

def load_mesh(resource: str) -> Tuple[Floats, npt.NDArray[np.int64]]:
    """Read an STL, OBJ or COLLADA file (a path, file:// or package://): (vertices (V, 3) float64
    in the file's units, triangles (T, 3) int64)."""
