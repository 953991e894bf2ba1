"""The Python module (crates/python) against the Rust path on the same grasps, in one run:

1. 1,000,000 planar grasps in one grasp_orient.solve call, against the same grasps answered
   through the root crate's answer layer on one core, without Python: in slices of 64 through its
   batch path (`Answering::answer_many::<Candidates>`, as the module answers them: the baseline of
   the target) and one by one (`Answering::answer::<Candidates>`, as `grasp_orient solve` answers
   its lines);
2. 100,000 gripper poses on a 100,352-triangle torus in one grasp_orient.solve_poses call, against
   the same poses as one pose set through `Answering::answer::<PoseSets>` on one core (the path
   `cargo bench --bench poses` times), the mesh indexed in both.

The Rust path is crates/python/benches/rust_path.rs, built and run here by cargo on files this
script writes (the same numbers, the poses' quaternions the ones the module made of their
matrices). The rounds alternate between the module and the Rust path. The module is timed on one thread (threads=1: the same work as the Rust path, plus
reading the arrays and writing the columns) and on every core (the default). Each figure is the
median of --rounds rounds; the ratios are module / Rust (target: at most 1.2 on one thread). On
one thread both are also timed on a core (the calling thread's CPU time,
CLOCK_THREAD_CPUTIME_ID), which other processes' time slices on a shared machine do not reach.

    bash tests/python/setup.sh --release     # the module in release, into its venv
    "$(bash tests/python/setup.sh --release | tail -n1)" benches/bench_python.py

docs/performance.md has the figures of a run.
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import grasp_orient

REPO = Path(__file__).resolve().parent.parent


def planar_grasps(n: int, seed: int = 1) -> dict:
    """Antipodal-ish planar grasps: contacts across the origin, normals pointing in with noise."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(-math.pi, math.pi, n)
    d = np.stack([np.cos(phi), np.sin(phi), np.zeros(n)], axis=1)
    r = rng.uniform(0.02, 0.08, (n, 1))
    def tilt(v):
        a = rng.normal(scale=0.25, size=n)
        c, s = np.cos(a), np.sin(a)
        return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], np.zeros(n)], axis=1)
    g_angle = rng.uniform(-math.pi, math.pi, n)
    return {
        "contact_1": r * d, "normal_1": tilt(-d), "contact_2": -r * d, "normal_2": tilt(d),
        "center_of_mass": np.concatenate([rng.normal(scale=0.01, size=(n, 2)), np.zeros((n, 1))], axis=1),
        "gravity": np.stack([9.81 * np.sin(g_angle), -9.81 * np.cos(g_angle), np.zeros(n)], axis=1),
        "mass": rng.uniform(0.05, 1.0, n), "friction": rng.uniform(0.3, 1.0, n),
    }


def torus(major: float = 0.05, minor: float = 0.015, k: int = 224):
    """A closed torus about z of 2·k² triangles, outward."""
    u = np.arange(k) * 2 * math.pi / k
    uu, vv = np.meshgrid(u, u, indexing="ij")
    x = (major + minor * np.cos(vv)) * np.cos(uu)
    y = (major + minor * np.cos(vv)) * np.sin(uu)
    z = minor * np.sin(vv)
    vertices = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = i * k + j
    b = ((i + 1) % k) * k + j
    c = ((i + 1) % k) * k + (j + 1) % k
    d = i * k + (j + 1) % k
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return vertices, triangles.astype(np.int64)


def poses_on_torus(n: int, major: float = 0.05, seed: int = 2):
    """Tool frames on the tube's centre circle, the closing axis (y) across the tube at a random
    angle about the tube, opening 0.05 m."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0, 2 * math.pi, n)
    psi = rng.uniform(0, 2 * math.pi, n)
    radial = np.stack([np.cos(phi), np.sin(phi), np.zeros(n)], 1)
    tangent = np.stack([-np.sin(phi), np.cos(phi), np.zeros(n)], 1)
    up = np.tile([0.0, 0.0, 1.0], (n, 1))
    y = np.cos(psi)[:, None] * radial + np.sin(psi)[:, None] * up
    x = tangent
    z = np.cross(x, y)
    poses = np.zeros((n, 4, 4))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2] = x, y, z
    poses[:, :3, 3] = major * radial
    poses[:, 3, 3] = 1.0
    return poses, np.full(n, 0.05)


def timed(f):
    """The wall time and the calling thread's time on a core of f(), in seconds; what f returns is
    freed after both are read (freeing a million rows' columns is not part of the call)."""
    start, core = time.perf_counter(), time.thread_time()
    out = f()
    wall, core = time.perf_counter() - start, time.thread_time() - core
    del out
    return wall, core


def build_rust_path() -> Path:
    """The Rust path's executable, built by cargo (bench profile)."""
    done = subprocess.run(["cargo", "bench", "-p", "grasp_orient_python", "--bench", "rust_path", "--no-run",
                           "--message-format=json"], cwd=REPO, check=True, capture_output=True, text=True)
    for line in done.stdout.splitlines():
        if '"executable":"' in line and "rust_path" in line:
            return Path(line.split('"executable":"')[1].split('"')[0])
    raise SystemExit("cargo built no rust_path executable")


def rust_round(exe: Path, folder: Path) -> dict:
    """One round of the Rust path: {"grasps": (n, wall s, on-core s), "grasps_batch": ..., "poses": ...}."""
    done = subprocess.run([str(exe), str(folder), "1"], check=True, capture_output=True, text=True)
    out = {}
    for line in done.stdout.splitlines():
        name, n, seconds, core = line.split()
        out[name] = (int(n), float(seconds), float(core))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grasps", type=int, default=1_000_000)
    ap.add_argument("--poses", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()

    grasps = planar_grasps(args.grasps)
    vertices, triangles = torus()
    poses, widths = poses_on_torus(args.poses)
    gravity = (0.0, 0.0, -9.81)
    solve_one = lambda: grasp_orient.solve(**grasps, model="planar", threads=1)  # noqa: E731
    solve_all = lambda: grasp_orient.solve(**grasps, model="planar")  # noqa: E731
    poses_one = lambda: grasp_orient.solve_poses(  # noqa: E731
        vertices, triangles, poses, widths, 0.3, 0.5, gravity, threads=1)
    poses_all = lambda: grasp_orient.solve_poses(  # noqa: E731
        vertices, triangles, poses, widths, 0.3, 0.5, gravity)
    ours, pose_out = solve_one(), poses_one()
    ok = int((ours["status"] == 0).sum())
    pose_ok = int((pose_out["status"] == 0).sum())

    exe = build_rust_path()
    keys = ("t_one", "t_all", "p_one", "p_all", "r_grasps", "r_batch", "r_poses", "c_one", "c_batch", "c_p_one", "c_poses")
    times = {k: [] for k in keys}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = np.concatenate([grasps["contact_1"], grasps["normal_1"], grasps["contact_2"], grasps["normal_2"],
                               grasps["center_of_mass"], grasps["gravity"], grasps["mass"][:, None],
                               grasps["friction"][:, None]], axis=1)
        rows.astype("<f8").tofile(folder / "grasps.f64")
        vertices.astype("<f8").tofile(folder / "vertices.f64")
        triangles.astype("<u4").tofile(folder / "triangles.u32")
        np.concatenate([poses[:, :3, 3], pose_out["grasp_orientation"], widths[:, None]], axis=1) \
            .astype("<f8").tofile(folder / "poses.f64")
        np.array([0.3, 0.5, *gravity, 1.0]).astype("<f8").tofile(folder / "object.f64")
        # Rounds interleaved, the module and the Rust path in turn, so that a slow moment of a
        # shared machine slows both alike; medians over the rounds.
        for _ in range(args.rounds):
            for key, core_key, f in (("t_one", "c_one", solve_one), ("t_all", None, solve_all),
                                     ("p_one", "c_p_one", poses_one), ("p_all", None, poses_all)):
                wall, core = timed(f)
                times[key].append(wall)
                if core_key:
                    times[core_key].append(core)
            rust = rust_round(exe, folder)
            times["r_grasps"].append(rust["grasps"][1])
            times["r_batch"].append(rust["grasps_batch"][1])
            times["c_batch"].append(rust["grasps_batch"][2])
            times["r_poses"].append(rust["poses"][1])
            times["c_poses"].append(rust["poses"][2])
    t_one, t_all, p_one, p_all, r_grasps, r_batch, r_poses, c_one, c_batch, c_p_one, c_poses = (
        statistics.median(times[k]) for k in keys)
    n, m = rust["grasps"][0], rust["poses"][0]
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {os.cpu_count()} cores; medians of {args.rounds} rounds")
    print(f"{n:,} planar grasps ({ok:,} solved), one solve call:")
    print(f"  module, threads=1:   {t_one:.3f} s ({t_one / n * 1e6:.3f} us a grasp)")
    print(f"  module, every core:  {t_all:.3f} s ({t_all / n * 1e6:.3f} us a grasp)")
    print(f"  Rust Answering (one candidate at a time), one core: {r_grasps:.3f} s ({r_grasps / n * 1e6:.3f} us a grasp)")
    print(f"  Rust Answering::answer_many (the batch path, slices of 64), one core: {r_batch:.3f} s "
          f"({r_batch / n * 1e6:.3f} us a grasp)")
    print(f"  ratio module / Rust batch: {t_one / r_batch:.3f} on one thread (target <= 1.2), "
          f"{t_all / r_batch:.3f} on every core; module / Rust one by one: {t_one / r_grasps:.3f}")
    print(f"  on a core, one thread: module {c_one / n * 1e6:.3f} us a grasp, Rust batch {c_batch / n * 1e6:.3f} us: "
          f"ratio {c_one / c_batch:.3f}")
    print(f"{m:,} poses on a {len(triangles):,}-triangle torus ({pose_ok:,} solved), one solve_poses call:")
    print(f"  module, threads=1:   {p_one:.3f} s ({p_one / m * 1e6:.3f} us a pose)")
    print(f"  module, every core:  {p_all:.3f} s ({p_all / m * 1e6:.3f} us a pose)")
    print(f"  Rust Answering (one pose set), one core: {r_poses:.3f} s ({r_poses / m * 1e6:.3f} us a pose)")
    print(f"  ratio module / Rust: {p_one / r_poses:.3f} on one thread (target <= 1.2), {p_all / r_poses:.3f} on every core")
    print(f"  on a core, one thread: module {c_p_one / m * 1e6:.3f} us a pose, Rust {c_poses / m * 1e6:.3f} us: "
          f"ratio {c_p_one / c_poses:.3f}")


if __name__ == "__main__":
    main()
