"""grasp_orient.solve against `grasp_orient solve` on the same candidates: every field of every row,
to the last bit, for the paper's reference cases (planar), the spatial examples, random grasps
(many of them refused or without force closure) and the options that solve's flags mirror."""
from __future__ import annotations

import json
import threading
import time

import numpy as np
import pytest

import grasp_orient
from cli import compare, grasp_lines, run_solve
from conftest import REPO_ROOT

VECTORS = ("contact_1", "normal_1", "contact_2", "normal_2", "center_of_mass", "gravity")


def arrays_of(lines: list[dict]) -> dict:
    """The module's arguments for JSON candidate lines."""
    out = {k: np.array([[l[k]["x"], l[k]["y"], l[k].get("z", 0.0)] for l in lines]) for k in VECTORS}
    out["mass"] = np.array([l["mass"] for l in lines])
    out["friction"] = np.array([[l["friction_1"], l["friction_2"]] for l in lines])
    return out


def example(name: str) -> list[dict]:
    return [json.loads(l) for l in (REPO_ROOT / "examples" / name).read_text().splitlines() if l.strip()]


def solve_both(solve_bin, lines, model: str, flags=(), **options):
    ours = grasp_orient.solve(**arrays_of(lines), model=model, **options)
    theirs = run_solve(solve_bin, lines, *flags)
    return ours, theirs


def test_the_papers_cases_are_solves_answers(solve_bin):
    lines = example("paper_cases.jsonl")
    ours, theirs = solve_both(solve_bin, lines, "planar")
    assert compare(ours, theirs) > 100
    # The paper's Table 1, as tests/it/paper.rs holds the solver to it: every case is solved.
    assert list(ours["status"]) == [0, 0, 0, 0]
    assert ours["rotation"].shape == (4, 4) and ours["rotation_axis"].shape == (4, 3)


@pytest.mark.parametrize("flags,options", [
    (["--objective", "norm1"], {"objective": "norm1"}),
    (["--objective", "internal_force", "--range", "graspable"], {"objective": "internal_force", "range": "graspable"}),
    (["--range=-0.2:0.3"], {"range": (-0.2, 0.3)}),
    (["--max-grip-force", "1.5", "--gripper-drive", "independent"], {"max_grip_force": 1.5, "gripper_drive": "independent"}),
    (["--friction-safety-factor", "1.3"], {"friction_safety_factor": 1.3}),
    (["--mass-tolerance", "0.01", "--center-of-mass-tolerance", "0.002,0.001,0"],
     {"mass_tolerance": 0.01, "center_of_mass_tolerance": (0.002, 0.001, 0.0)}),
])
def test_options_mean_what_solves_flags_mean(solve_bin, flags, options):
    lines = example("paper_cases.jsonl") + example("spatial_cases.jsonl")
    planar = [l for l in lines if l.get("model", 0) == 0]
    spatial = [l for l in lines if l.get("model", 0) == 1]
    for model, subset in (("planar", planar), ("spatial", spatial)):
        ours, theirs = solve_both(solve_bin, subset, model, flags, **options)
        compare(ours, theirs)
    if "max_grip_force" in options:
        assert 3 in set(ours["status"]) | set(grasp_orient.solve(**arrays_of(planar), model="planar", **options)["status"])


def test_the_spatial_examples_are_solves_answers(solve_bin):
    lines = example("spatial_cases.jsonl")
    ours, theirs = solve_both(solve_bin, lines, "spatial")
    compare(ours, theirs)
    assert 0 in set(int(s) for s in ours["status"])


def random_grasps(n: int, seed: int) -> dict:
    """Grasps across the whole range: contacts on a sphere with noisy inward normals, some refused
    (coincident contacts, zero normals, friction or mass not positive), some without force
    closure."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = rng.uniform(0.01, 0.1, size=(n, 1))
    c1, c2 = r * d, -r * d
    n1 = -d + rng.normal(scale=0.6, size=(n, 3))
    n2 = d + rng.normal(scale=0.6, size=(n, 3))
    com = rng.normal(scale=0.02, size=(n, 3))
    g = rng.normal(size=(n, 3))
    g *= 9.81 / np.linalg.norm(g, axis=1, keepdims=True)
    mass = rng.uniform(0.05, 2.0, size=n)
    friction = rng.uniform(0.1, 1.2, size=(n, 2))
    k = n // 10
    c2[:k // 4] = c1[:k // 4]                      # contacts coincide
    n1[k // 4:k // 2] = 0.0                        # a zero normal
    mass[k // 2:3 * k // 4] = -1.0                 # mass not positive
    friction[3 * k // 4:k, 0] = 0.0                # friction not positive
    return {"contact_1": c1, "normal_1": n1, "contact_2": c2, "normal_2": n2, "center_of_mass": com,
            "gravity": g, "mass": mass, "friction": friction}


@pytest.mark.parametrize("model,code", [("spatial", 1), ("planar", 0)])
def test_random_grasps_and_refusals_are_solves_answers(solve_bin, model, code):
    a = random_grasps(600, seed=7 + code)
    ours = grasp_orient.solve(**a, model=model)
    theirs = run_solve(solve_bin, grasp_lines(*(a[k] for k in (*VECTORS, "mass", "friction")), model=code))
    compare(ours, theirs)
    statuses = set(int(s) for s in ours["status"])
    assert {0, 1, 2} <= statuses, statuses
    refused = [m for s, m in zip(ours["status"], ours["message"]) if s == 2]
    assert refused and all(m.startswith("row ") for m in refused)


def test_one_friction_a_row_is_both_contacts():
    a = random_grasps(50, seed=3)
    both = a["friction"][:, 0].copy()
    one = grasp_orient.solve(**{**a, "friction": both})
    two = grasp_orient.solve(**{**a, "friction": np.stack([both, both], axis=1)})
    for k, v in one.items():
        if isinstance(v, list):
            assert v == two[k]
        else:
            np.testing.assert_array_equal(v, two[k])


def test_every_thread_count_gives_the_same_answer():
    a = random_grasps(20_000, seed=11)
    one = grasp_orient.solve(**a, threads=1)
    for threads in (None, 3):
        other = grasp_orient.solve(**a, threads=threads)
        for k, v in one.items():
            if isinstance(v, list):
                assert v == other[k], k
            else:
                np.testing.assert_array_equal(v, other[k], err_msg=k)


def test_an_empty_batch_gives_empty_columns():
    empty = {k: np.zeros((0, 3)) for k in VECTORS}
    out = grasp_orient.solve(**empty, mass=np.zeros(0), friction=np.zeros(0))
    assert out["status"].shape == (0,) and out["rotation"].shape == (0, 4) and out["message"] == []


def test_the_gil_is_released_while_solving():
    a = random_grasps(200_000, seed=5)
    a = {k: (np.tile(v, (1,) * v.ndim) if v.ndim == 1 else v) for k, v in a.items()}
    done = []
    worker = threading.Thread(target=lambda: done.append(grasp_orient.solve(**a, model="planar", threads=1)))
    started = time.perf_counter()
    worker.start()
    ticks = 0
    while worker.is_alive():
        ticks += 1
        time.sleep(0)
    elapsed = time.perf_counter() - started
    worker.join()
    assert done and len(done[0]["status"]) == 200_000
    # With the GIL held for the whole call this thread would not run until it returned.
    assert elapsed > 0.05 and ticks > 100, (elapsed, ticks)
