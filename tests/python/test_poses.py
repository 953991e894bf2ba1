"""grasp_orient.solve_poses and load_mesh against `grasp_orient solve` on the same pose candidates:
every field of every pose, to the last bit, on meshes/block_mm.obj (read by load_mesh, and the same
file named as a resource), and on primitives made into meshes (a box, a cylinder, a sphere), with
poses that are refused (a finger on nothing, a finger starting inside, an opening narrower than
the object)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import grasp_orient
from cli import compare, point, run_solve
from conftest import REPO_ROOT

BLOCK = REPO_ROOT / "meshes" / "block_mm.obj"
GRAVITY = (0.0, 0.0, -9.81)


def rotation(rng) -> np.ndarray:
    """A random rotation matrix (QR of a Gaussian matrix, signs fixed, determinant +1)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def poses_around(n: int, size: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Tool frames near an object of about `size` (m) at the origin, and openings: most close on
    it, some start inside it or miss it."""
    rng = np.random.default_rng(seed)
    poses = np.zeros((n, 4, 4))
    for i in range(n):
        poses[i, :3, :3] = rotation(rng)
        poses[i, :3, 3] = rng.normal(scale=size / 4, size=3)
        poses[i, 3, 3] = 1.0
    widths = rng.uniform(1.5 * size, 3.0 * size, size=n)
    widths[: n // 10] = size / 10                                  # narrower than the object
    poses[n // 10: n // 5, :3, 3] += np.array([0.0, 0.0, 3 * size])  # above it: may close on nothing
    return poses, widths


def box_mesh(a: float, b: float, c: float):
    v = np.array([[x, y, z] for x in (-a / 2, a / 2) for y in (-b / 2, b / 2) for z in (-c / 2, c / 2)])
    # The faces of meshes/block_mm.obj's corner order (x, then y, then z), outward.
    t = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return v, t


def cylinder_mesh(height: float, radius: float, k: int = 48):
    ring = [(radius * math.cos(2 * math.pi * j / k), radius * math.sin(2 * math.pi * j / k)) for j in range(k)]
    v = [[x, y, -height / 2] for x, y in ring] + [[x, y, height / 2] for x, y in ring]
    v += [[0.0, 0.0, -height / 2], [0.0, 0.0, height / 2]]
    bottom, top = 2 * k, 2 * k + 1
    t = []
    for j in range(k):
        j2 = (j + 1) % k
        t += [[j, j2, k + j2], [j, k + j2, k + j], [bottom, j2, j], [top, k + j, k + j2]]
    return np.array(v), np.array(t)


def sphere_mesh(radius: float, rings: int = 16, sectors: int = 32):
    v = [[0.0, 0.0, radius]]
    for r in range(1, rings):
        th = math.pi * r / rings
        for s in range(sectors):
            ph = 2 * math.pi * s / sectors
            v.append([radius * math.sin(th) * math.cos(ph), radius * math.sin(th) * math.sin(ph), radius * math.cos(th)])
    v.append([0.0, 0.0, -radius])
    south = len(v) - 1
    idx = lambda r, s: 1 + (r - 1) * sectors + s % sectors  # noqa: E731
    t = [[0, idx(1, s), idx(1, s + 1)] for s in range(sectors)]
    for r in range(1, rings - 1):
        for s in range(sectors):
            t += [[idx(r, s), idx(r + 1, s), idx(r + 1, s + 1)], [idx(r, s), idx(r + 1, s + 1), idx(r, s + 1)]]
    t += [[south, idx(rings - 1, s + 1), idx(rings - 1, s)] for s in range(sectors)]
    return np.array(v), np.array(t)


def pose_lines(out: dict, poses: np.ndarray, widths: np.ndarray, obj: dict, gravity=GRAVITY) -> list[dict]:
    """PoseCandidate lines of the poses, each with the quaternion the module made of its rotation."""
    lines = []
    for i in range(len(widths)):
        q = out["grasp_orientation"][i]
        lines.append({
            "id": f"pose-{i}",
            "grasp_pose": {"position": point(poses[i, :3, 3]),
                           "orientation": {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}},
            "width": float(widths[i]), "object": obj, "gravity": point(gravity),
        })
    return lines


def inline_object(vertices, triangles, mass, friction, scale=1.0, center_of_mass=None) -> dict:
    obj = {
        "pose": {"position": point((0, 0, 0)), "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
        "inline_mesh": {"vertices": [point(v) for v in vertices],
                        "triangles": [{"vertex_indices": [int(i) for i in t]} for t in triangles]},
        "scale": point((scale, scale, scale)), "mass": mass, "friction": friction,
    }
    if center_of_mass is not None:
        obj["has_center_of_mass"] = True
        obj["center_of_mass"] = point(center_of_mass)
    return obj


def test_load_mesh_reads_the_block():
    vertices, triangles = grasp_orient.load_mesh(str(BLOCK))
    assert vertices.dtype == np.float64 and vertices.shape[1] == 3
    assert triangles.dtype == np.int64 and triangles.shape == (12, 3)
    # Its own reading of the OBJ file: "v x y z" and 1-based "f a b c" lines; the reader may repeat
    # a vertex for each triangle it belongs to, so the triangles' corners are compared.
    words = [line.split() for line in BLOCK.read_text().splitlines()]
    v = np.array([[float(x) for x in w[1:4]] for w in words if w and w[0] == "v"])
    f = np.array([[int(i) - 1 for i in w[1:4]] for w in words if w and w[0] == "f"])
    np.testing.assert_array_equal(vertices[triangles], v[f])


def test_load_mesh_refuses_what_it_cannot_read(tmp_path):
    with pytest.raises(ValueError, match="nothing.stl"):
        grasp_orient.load_mesh(str(tmp_path / "nothing.stl"))
    bad = tmp_path / "bad.obj"
    bad.write_text("f 1 2 3\n")
    with pytest.raises(ValueError, match="bad.obj"):
        grasp_orient.load_mesh(str(bad))


@pytest.mark.parametrize("closing_axis", ["y", "x"])
def test_poses_on_the_block_are_solves_answers(solve_bin, closing_axis):
    vertices, triangles = grasp_orient.load_mesh(str(BLOCK))
    poses, widths = poses_around(300, 0.08, seed=1 if closing_axis == "y" else 2)
    out = grasp_orient.solve_poses(vertices, triangles, poses, widths, 0.25, 0.5, GRAVITY,
                                   closing_axis=closing_axis, scale=0.001)
    obj = inline_object(vertices, triangles, 0.25, 0.5, scale=0.001)
    theirs = run_solve(solve_bin, pose_lines(out, poses, widths, obj), "--closing-axis", closing_axis)
    compare(out, theirs, poses=True)
    statuses = set(int(s) for s in out["status"])
    assert {0, 1, 2} <= statuses, statuses
    refused = out["status"] != 0
    assert np.isnan(out["contact_1"][refused & (out["status"] == 2)]).all()
    # The same file named as a resource answers every pose alike (a message may name the mesh).
    by_file = {**obj, "mesh": str(BLOCK)}
    del by_file["inline_mesh"]
    from_file = run_solve(solve_bin, pose_lines(out, poses, widths, by_file), "--closing-axis", closing_axis)
    for i, line in enumerate(from_file):
        assert line["recommendation"]["status"] == out["status"][i]
        if out["status"][i] == 0:
            assert line["recommendation"]["gripping_power"] == out["gripping_power"][i]


@pytest.mark.parametrize("shape", ["box", "cylinder", "sphere"])
def test_poses_on_primitives_as_meshes_are_solves_answers(solve_bin, shape):
    vertices, triangles = {"box": lambda: box_mesh(0.04, 0.06, 0.08),
                           "cylinder": lambda: cylinder_mesh(0.12, 0.033),
                           "sphere": lambda: sphere_mesh(0.035)}[shape]()
    poses, widths = poses_around(200, 0.08, seed=len(shape))
    com = (0.002, -0.001, 0.003)
    out = grasp_orient.solve_poses(vertices, triangles.astype(np.int32), poses, widths, 0.3, 0.6, GRAVITY,
                                   center_of_mass=com, objective="norm1", max_grip_force=20.0)
    obj = inline_object(vertices, triangles, 0.3, 0.6, center_of_mass=com)
    theirs = run_solve(solve_bin, pose_lines(out, poses, widths, obj), "--objective", "norm1",
                       "--max-grip-force", "20")
    compare(out, theirs, poses=True)
    assert 0 in set(int(s) for s in out["status"])
    ok = out["status"] == 0
    np.testing.assert_array_equal(out["center_of_mass"][ok], np.tile(com, (ok.sum(), 1)))


def test_a_mesh_the_geometry_refuses_refuses_every_pose(solve_bin):
    vertices, triangles = box_mesh(0.04, 0.06, 0.08)
    open_box = triangles[:-2]  # two faces missing: no centroid, so no centre of mass
    poses, widths = poses_around(20, 0.08, seed=9)
    out = grasp_orient.solve_poses(vertices, open_box, poses, widths, 0.3, 0.6, GRAVITY)
    theirs = run_solve(solve_bin, pose_lines(out, poses, widths, inline_object(vertices, open_box, 0.3, 0.6)))
    compare(out, theirs, poses=True)
    assert set(int(s) for s in out["status"]) == {2}
    assert all(m.startswith(f"row {i}: ") for i, m in enumerate(out["message"]))


def test_every_thread_count_gives_the_same_poses():
    vertices, triangles = sphere_mesh(0.035, rings=40, sectors=80)
    poses, widths = poses_around(20_000, 0.08, seed=4)
    one = grasp_orient.solve_poses(vertices, triangles, poses, widths, 0.3, 0.6, GRAVITY, threads=1)
    other = grasp_orient.solve_poses(vertices, triangles, poses, widths, 0.3, 0.6, GRAVITY, threads=3)
    for k, v in one.items():
        if isinstance(v, list):
            assert v == other[k], k
        else:
            np.testing.assert_array_equal(v, other[k], err_msg=k)


def rotation_of(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion (x, y, z, w), written out."""
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


@pytest.mark.parametrize("closing_axis,column", [("x", 0), ("y", 1), ("z", 2)])
def test_each_pose_is_its_matrix_and_the_fingers_close_along_its_axis(closing_axis, column):
    # The quaternion the module made of each matrix gives the matrix back, and the contacts lie on
    # the line through the tool frame's origin along the closing axis's column: checks of the
    # conversion that share nothing with it.
    vertices, triangles = sphere_mesh(0.035)
    rng = np.random.default_rng(column)
    poses = np.zeros((200, 4, 4))
    for i in range(200):
        poses[i, :3, :3] = rotation(rng)
        poses[i, :3, 3] = rng.normal(scale=0.005, size=3)
        poses[i, 3, 3] = 1.0
    out = grasp_orient.solve_poses(vertices, triangles, poses, np.full(200, 0.1), 0.2, 0.5, GRAVITY,
                                   closing_axis=closing_axis)
    for i in range(200):
        np.testing.assert_allclose(rotation_of(out["grasp_orientation"][i]), poses[i, :3, :3], atol=1e-12)
    ok = out["status"] != 2
    assert ok.sum() > 150
    axis = poses[ok, :3, column]
    for c in ("contact_1", "contact_2"):
        offset = out[c][ok] - poses[ok, :3, 3]
        np.testing.assert_allclose(np.cross(offset, axis), 0.0, atol=1e-9)
    # Finger 1 starts on the negative side of the axis, finger 2 on the positive.
    along = np.einsum("ij,ij->i", out["contact_2"][ok] - out["contact_1"][ok], axis)
    assert (along > 0).all()


def test_tool_poses_are_the_poses_turned_about_the_grasp_centre():
    """tool_pose (N, 7) against numpy: each pose's matrix turned by the answer's rotation (Rodrigues from
    rotation_axis and wrist_rotation, not the answer's quaternion) about the midpoint m of its contacts,
    R @ R_tool at m + R (t - m); NaN where the answer has no rotation."""
    vertices, triangles = box_mesh(0.04, 0.06, 0.08)
    poses, widths = poses_around(300, 0.08, seed=11)
    out = grasp_orient.solve_poses(vertices, triangles, poses, widths, 0.3, 0.6, GRAVITY,
                                   center_of_mass=(0.004, -0.006, 0.01))
    assert out["tool_pose"].shape == (300, 7) and out["tool_pose"].dtype == np.float64
    turned = 0
    for i in range(300):
        if not np.isfinite(out["rotation"][i]).all():
            assert np.isnan(out["tool_pose"][i]).all(), (i, out["tool_pose"][i])
            continue
        k = out["rotation_axis"][i]
        kk = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        phi = out["wrist_rotation"][i]
        r = np.eye(3) + math.sin(phi) * kk + (1 - math.cos(phi)) * kk @ kk
        m = (out["contact_1"][i] + out["contact_2"][i]) / 2
        t = poses[i, :3, 3]
        np.testing.assert_allclose(out["tool_pose"][i, :3], m + r @ (t - m), rtol=0, atol=1e-12)
        np.testing.assert_allclose(rotation_of(out["tool_pose"][i, 3:]), r @ poses[i, :3, :3], rtol=0, atol=1e-12)
        turned += 1
    big = int((out["wrist_rotation"][np.isfinite(out["wrist_rotation"])] > 0.1).sum())
    assert turned >= 40 and big >= 10, (turned, big)
