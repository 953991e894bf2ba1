"""Bad arrays and options: each is a ValueError that names the argument (and the row and column of a
value), raised before anything is solved, and never a crash. Run in a child process where a crash
could kill the interpreter, so that a segfault fails the test instead of ending the run."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import grasp_orient
from test_poses import GRAVITY, box_mesh

N = 5


def grasps(**changed):
    a = {
        "contact_1": np.tile([0.0, 0.05, 0.0], (N, 1)), "normal_1": np.tile([0.0, -1.0, 0.0], (N, 1)),
        "contact_2": np.tile([0.0, -0.05, 0.0], (N, 1)), "normal_2": np.tile([0.0, 1.0, 0.0], (N, 1)),
        "center_of_mass": np.zeros((N, 3)), "gravity": np.tile([0.0, 0.0, -9.81], (N, 1)),
        "mass": np.full(N, 0.2), "friction": np.full(N, 0.5),
    }
    a.update(changed)
    return a


def test_the_good_arrays_are_solved():
    assert list(grasp_orient.solve(**grasps())["status"]) == [0] * N


def nan_at(row, col):
    c = np.tile([0.0, 0.05, 0.0], (N, 1))
    c[row, col] = np.nan
    return c


@pytest.mark.parametrize("changed,words", [
    ({"contact_1": np.zeros((N, 2))}, r"contact_1: expected an array of shape \(N, 3\), got shape \(5, 2\)"),
    ({"normal_2": np.zeros(3 * N)}, r"normal_2: expected an array of shape \(N, 3\), got shape \(15,\)"),
    ({"gravity": np.zeros((N + 1, 3))}, r"gravity: 6 rows, but contact_1 has 5"),
    ({"mass": np.full(N - 1, 0.2)}, r"mass: 4 rows, but contact_1 has 5"),
    ({"friction": np.full((N, 3), 0.5)}, r"friction: expected an array of shape \(N, 2\)"),
    ({"contact_1": nan_at(3, 1)}, r"contact_1\[3, 1\] is NaN"),
    ({"mass": np.array([0.2, 0.2, np.inf, 0.2, 0.2])}, r"mass\[2\] is inf"),
    ({"center_of_mass": np.zeros((N, 3), dtype=np.float32)}, r"center_of_mass: expected dtype float64, got float32"),
    ({"mass": np.full(N, 1, dtype=np.int64)}, r"mass: expected dtype float64, got int64"),
    ({"normal_1": np.ascontiguousarray(np.asfortranarray(np.tile([0.0, -1.0, 0.0], (N, 1))))}, None),
    ({"contact_2": np.asfortranarray(np.tile([0.0, -0.05, 0.0], (N, 1)))}, r"contact_2: the array is not C-contiguous"),
    ({"gravity": np.tile([0.0, 0.0, -9.81], (2 * N, 1))[::2]}, r"gravity: the array is not C-contiguous"),
    ({"contact_1": [[0.0, 0.05, 0.0]] * N}, r"contact_1: expected a numpy array, got list"),
])
def test_a_bad_array_is_a_value_error_naming_it(changed, words):
    if words is None:  # a C-contiguous copy is fine
        grasp_orient.solve(**grasps(**changed))
        return
    with pytest.raises(ValueError, match=words):
        grasp_orient.solve(**grasps(**changed))


@pytest.mark.parametrize("rows,first,then", [(300, (250, 2), (260, 0)), (300, (22, 0), (22, 2)), (7, (6, 2), None)])
def test_the_first_value_not_finite_is_named_in_a_large_array(rows, first, then):
    """The check reads blocks of values; the one named is still the first in C order."""
    c = np.tile([0.0, 0.05, 0.0], (rows, 1))
    c[first] = np.inf
    if then is not None:
        c[then] = np.nan
    a = {k: np.resize(v, (rows, *v.shape[1:])) for k, v in grasps().items()}
    with pytest.raises(ValueError, match=rf"contact_1\[{first[0]}, {first[1]}\] is inf"):
        grasp_orient.solve(**{**a, "contact_1": c})


@pytest.mark.parametrize("option,words", [
    ({"objective": "norm3"}, "objective"),
    ({"model": "flat"}, "model"),
    ({"range": "anywhere"}, "range"),
    ({"range": (0.3, -0.2)}, "range_min"),
    ({"gripper_drive": "both"}, "gripper_drive"),
    ({"max_grip_force": -1.0}, "max_grip_force"),
    ({"friction_safety_factor": 0.5}, "friction_safety_factor"),
    ({"center_of_mass_tolerance": (0.0, -0.1, 0.0)}, "center_of_mass_tolerance"),
    ({"center_of_mass_tolerance": (0.0, 0.1)}, "center_of_mass_tolerance"),
    ({"mass_tolerance": float("nan")}, "mass_tolerance"),
    ({"threads": 0}, "threads"),
])
def test_a_bad_option_is_a_value_error_naming_it(option, words):
    with pytest.raises(ValueError, match=words):
        grasp_orient.solve(**grasps(), **option)


def poses_args(**changed):
    v, t = box_mesh(0.04, 0.06, 0.08)
    poses = np.tile(np.eye(4), (N, 1, 1))
    a = {"vertices": v, "triangles": t, "poses": poses, "widths": np.full(N, 0.1),
         "mass": 0.2, "friction": 0.5, "gravity": GRAVITY}
    a.update(changed)
    return a


def test_the_good_poses_are_solved():
    assert len(grasp_orient.solve_poses(**poses_args())["status"]) == N


def sheared():
    p = np.tile(np.eye(4), (N, 1, 1))
    p[3, 0, 1] = 0.5
    return p


def not_rigid():
    p = np.tile(np.eye(4), (N, 1, 1))
    p[2, 3, 0] = 1.0
    return p


def mirrored():
    p = np.tile(np.eye(4), (N, 1, 1))
    p[1, 0, 0] = -1.0
    return p


@pytest.mark.parametrize("changed,words", [
    ({"poses": np.tile(np.eye(4), (N, 1))}, r"poses: expected an array of shape \(N, 4, 4\)"),
    ({"poses": np.tile(np.eye(4), (N, 1, 1)).transpose(0, 2, 1)}, r"poses: the array is not C-contiguous"),
    ({"poses": sheared()}, r"poses\[3\]: the upper-left 3x3 block is not a rotation"),
    ({"poses": mirrored()}, r"poses\[1\]: the upper-left 3x3 block is not a rotation"),
    ({"poses": not_rigid()}, r"poses\[2\]: the bottom row"),
    ({"widths": np.full(N + 1, 0.1)}, r"widths: 6 rows, but poses has 5"),
    ({"widths": np.array([0.1, np.nan, 0.1, 0.1, 0.1])}, r"widths\[1\] is NaN"),
    ({"vertices": box_mesh(0.04, 0.06, 0.08)[0].astype(np.float32)}, r"vertices: expected dtype float64"),
    ({"triangles": box_mesh(0.04, 0.06, 0.08)[1].astype(np.float64)}, r"triangles: expected an integer dtype"),
    ({"triangles": box_mesh(0.04, 0.06, 0.08)[1] + 1}, r"triangles\[\d+, \d\] is 8: not a row of vertices \(it has 8 rows\)"),
    ({"triangles": -box_mesh(0.04, 0.06, 0.08)[1] - 1}, r"triangles\[0, 0\] is -1"),
    ({"gravity": (0.0, 0.0)}, r"gravity: expected three numbers, got 2"),
    ({"gravity": (0.0, np.nan, -9.81)}, r"gravity\[1\] is NaN"),
    ({"mass": float("inf")}, r"mass is inf"),
])
def test_bad_poses_are_a_value_error_naming_them(changed, words):
    with pytest.raises(ValueError, match=words):
        grasp_orient.solve_poses(**poses_args(**changed))


@pytest.mark.parametrize("option,words", [
    ({"closing_axis": "w"}, "closing_axis"),
    ({"scale": (1.0, 1.0)}, "scale"),
    ({"scale": float("nan")}, "scale"),
    ({"center_of_mass": "middle"}, "center_of_mass"),
])
def test_bad_pose_options_are_a_value_error_naming_them(option, words):
    with pytest.raises(ValueError, match=words):
        grasp_orient.solve_poses(**poses_args(), **option)


def test_values_the_solver_refuses_are_rows_with_status_2_not_errors():
    # Numbers that are finite but wrong are the solver's to refuse, one row at a time, as solve
    # refuses a line: the batch goes on.
    out = grasp_orient.solve(**grasps(mass=np.array([0.2, -1.0, 0.2, 0.0, 0.2])))
    assert list(out["status"]) == [0, 2, 0, 2, 0]
    assert out["message"][1].startswith("row 1: ") and "mass" in out["message"][1]


def test_no_bad_input_crashes_the_interpreter():
    # Every refusal above once more, in a child interpreter, plus arrays of every dtype and rank:
    # the child must end normally whatever it was given.
    script = r"""
import itertools, numpy as np, grasp_orient
shapes = [(), (0,), (5,), (5, 3), (5, 2), (5, 3, 1), (0, 3)]
dtypes = [np.float64, np.float32, np.int64, np.uint8, np.complex128, object, bool, ">f8"]
errors = 0
for shape, dtype in itertools.product(shapes, dtypes):
    bad = np.zeros(shape, dtype=dtype)
    for k in range(8):
        args = [np.zeros((5, 3)) for _ in range(6)] + [np.ones(5), np.ones(5)]
        args[k] = bad
        try:
            grasp_orient.solve(*args)
        except ValueError:
            errors += 1
    for name in ("vertices", "triangles", "poses", "widths"):
        good = {"vertices": np.zeros((3, 3)), "triangles": np.array([[0, 1, 2]]), "poses": np.tile(np.eye(4), (5, 1, 1)), "widths": np.ones(5)}
        good[name] = bad
        try:
            grasp_orient.solve_poses(good["vertices"], good["triangles"], good["poses"], good["widths"], 1.0, 0.5, (0, 0, -9.81))
        except ValueError:
            errors += 1
print("errors", errors)
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, (done.returncode, done.stderr[-3000:])
    assert int(done.stdout.split()[-1]) > 300, done.stdout
